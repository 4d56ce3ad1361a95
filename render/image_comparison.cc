#include "render/image_comparison.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"

namespace mesocap::render {
namespace {

void ExpectSameShape(const core::Image& a, const core::Image& b, bool same_channels = true) {
  if (a.width() != b.width() || a.height() != b.height() || (same_channels && a.channels() != b.channels())) {
    throw core::Error("image comparison: sizes differ (" + std::to_string(a.width()) + "x" +
                      std::to_string(a.height()) + "x" + std::to_string(a.channels()) + " vs " +
                      std::to_string(b.width()) + "x" + std::to_string(b.height()) + "x" +
                      std::to_string(b.channels()) + ")");
  }
}

}  // namespace

double MaskIou(const core::Image& a, const core::Image& b) {
  ExpectSameShape(a, b);
  long both = 0, either = 0;
  for (int y = 0; y < a.height(); ++y) {
    for (int x = 0; x < a.width(); ++x) {
      const bool in_a = a.at(x, y) > 0.5f, in_b = b.at(x, y) > 0.5f;
      both += in_a && in_b;
      either += in_a || in_b;
    }
  }
  return either == 0 ? 1.0 : static_cast<double>(both) / static_cast<double>(either);
}

double Psnr(const core::Image& a, const core::Image& b) {
  ExpectSameShape(a, b);
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const double d = std::clamp(a.data()[i], 0.0f, 1.0f) - std::clamp(b.data()[i], 0.0f, 1.0f);
    sum += d * d;
  }
  const double mse = sum / static_cast<double>(a.size());
  return mse <= 1e-10 ? 100.0 : 10.0 * std::log10(1.0 / mse);
}

core::Image MaskDifference(const core::Image& rendered, const core::Image& truth, const core::Image& background) {
  ExpectSameShape(rendered, truth);
  ExpectSameShape(background, truth, /*same_channels=*/false);
  core::Image difference(truth.width(), truth.height(), 3);
  for (int y = 0; y < truth.height(); ++y) {
    for (int x = 0; x < truth.width(); ++x) {
      const float grey = 0.4f * std::clamp(background.at(x, y), 0.0f, 1.0f);
      const bool in_rendered = rendered.at(x, y) > 0.5f, in_truth = truth.at(x, y) > 0.5f;
      float* p = difference.pixel(x, y);
      p[0] = in_truth && !in_rendered ? 1.0f : grey;
      p[1] = in_rendered && !in_truth ? 1.0f : grey;
      p[2] = grey;
    }
  }
  return difference;
}

}  // namespace mesocap::render
