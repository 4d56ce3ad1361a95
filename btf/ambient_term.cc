#include "btf/ambient_term.h"

#include <string>

#include "core/error.h"

namespace mesocap::btf {

formats::AmbientTerm MakeAmbientTerm(int width, int height, const core::SamplingSet& views) {
  formats::AmbientTerm ambient;
  ambient.width = width;
  ambient.height = height;
  ambient.views = views;
  ambient.values = core::Image(width, height * views.size(), 3);
  return ambient;
}

void AddAmbientView(const core::Image& btf_view, const core::SamplingSet& lights, int view,
                    formats::AmbientTerm* ambient) {
  const int w = ambient->width;
  const int h = ambient->height;
  if (view < 0 || view >= ambient->view_count()) {
    throw core::Error("ambient term: view " + std::to_string(view) + " outside 0.." +
                      std::to_string(ambient->view_count() - 1));
  }
  if (btf_view.width() != w || btf_view.height() != h * lights.size() || btf_view.channels() != 3) {
    throw core::Error("ambient term: BTF view " + std::to_string(view) + " image is " +
                      std::to_string(btf_view.width()) + "x" + std::to_string(btf_view.height()) + ", expected " +
                      std::to_string(w) + "x" + std::to_string(h * lights.size()) + " with 3 channels");
  }
  float* out = ambient->values.pixel(0, view * h);
  for (int l = 0; l < lights.size(); ++l) {
    // Lights at or below the horizon (none in a valid set) would get cos <= 0.
    const double weight = lights.direction(l).z() * lights.weight(l);
    const float* t = btf_view.pixel(0, l * h);
    for (long long i = 0; i < 3LL * w * h; ++i) out[i] += static_cast<float>(weight * t[i]);
  }
}

formats::AmbientTerm ComputeAmbientTerm(const core::FullBtf& btf) {
  formats::AmbientTerm ambient = MakeAmbientTerm(btf.width, btf.height, btf.views);
  for (int v = 0; v < btf.view_count(); ++v) AddAmbientView(btf.view_images[v], btf.lights, v, &ambient);
  return ambient;
}

}  // namespace mesocap::btf
