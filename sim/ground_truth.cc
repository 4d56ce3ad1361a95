#include "sim/ground_truth.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>

#include "formats/material_manifest.h"
#include "formats/material_package_layout.h"
#include "formats/material_package_writer.h"

namespace mesocap::sim {
namespace {

constexpr double kNoFarLimit = std::numeric_limits<double>::infinity();

// Intersect's interval is closed, so geometry touching z = 0 (a flat sample,
// block tops) is hit at D = 0.
std::optional<SurfaceHit> FirstHitBelow(const MesostructureScene& scene, const Eigen::Vector3d& p,
                                        const Eigen::Vector3d& view) {
  return scene.Intersect(p, -view, 0.0, kNoFarLimit);
}

}  // namespace

core::CheckResult GroundTruthOptions::Check() const {
  if (auto problem = core::CheckImageSize(texels.width, texels.height, "texture size"); !problem.empty()) {
    return problem;
  }
  if (!(texels.sample_size_mm > 0.0) || !std::isfinite(texels.sample_size_mm)) return "sample size must be positive";
  if (views.size() == 0 || lights.size() == 0) return "view and light sets must not be empty";
  if (samples_per_side < 1 || samples_per_side > formats::kMaxTexelSamplesPerSide) {
    return "samples per side " + std::to_string(samples_per_side) + " must be 1.." +
           std::to_string(formats::kMaxTexelSamplesPerSide);
  }
  return {};
}

core::Mdf ComputeTrueMdf(const MesostructureScene& scene, const GroundTruthOptions& o) {
  core::Mdf mdf = core::MakeMdf(o.texels.width, o.texels.height, o.views);
  const calibration::TexelGrid grid = o.texels;
  tbb::parallel_for(0, o.views.size() * o.texels.height, [&](int row) {
    const int v = row / o.texels.height;
    const int j = row % o.texels.height;
    const Eigen::Vector3d& view = o.views.direction(v);
    for (int i = 0; i < o.texels.width; ++i) {
      const auto hit = FirstHitBelow(scene, grid.TexelCentre(i, j), view);
      mdf.at(i, j, v) = hit ? static_cast<float>(hit->distance) : core::MdfNoHit();
    }
  });
  return mdf;
}

core::FullBtf RenderTrueBtf(const MesostructureScene& scene, const GroundTruthOptions& options) {
  core::FullBtf btf = core::MakeFullBtf(options.texels.width, options.texels.height, options.views, options.lights);
  for (int v = 0; v < options.views.size(); ++v) btf.view_images[v] = RenderTrueBtfView(scene, options, v);
  return btf;
}

core::Image RenderTrueBtfView(const MesostructureScene& scene, const GroundTruthOptions& o, int v) {
  const int w = o.texels.width;
  const int h = o.texels.height;
  core::Image out(w, h * o.lights.size(), 3);
  const Eigen::Vector3d& view = o.views.direction(v);
  const calibration::TexelGrid grid = o.texels;
  const int n = o.samples_per_side;
  const float mean = 1.0f / static_cast<float>(n * n);
  tbb::parallel_for(0, h, [&](int j) {
    for (int i = 0; i < w; ++i) {
      for (int b = 0; b < n; ++b) {
        for (int a = 0; a < n; ++a) {
          // The centre of stratum (a, b) of the texel's square.
          const Eigen::Vector3d p =
              grid.TexelCentre(i, j) + Eigen::Vector3d(((a + 0.5) / n - 0.5) * grid.texel_width_mm(),
                                                       ((b + 0.5) / n - 0.5) * grid.texel_height_mm(), 0.0);
          const auto hit = FirstHitBelow(scene, p, view);
          if (!hit) continue;  // black backing under holes
          for (int l = 0; l < o.lights.size(); ++l) {
            const Eigen::Vector3d& light = o.lights.direction(l);
            const double n_dot_l = hit->normal.dot(light);
            // Shadow rays skip the surface they leave (surface_epsilon_mm).
            if (n_dot_l <= 0.0 || scene.Occluded(hit->point, light, scene.surface_epsilon_mm(), kNoFarLimit)) {
              continue;
            }
            // Divided by the irradiance on the reference plane, cos(theta_l):
            // the BTF is radiance per unit reference-plane irradiance.
            const Eigen::Vector3f t =
                hit->reflectance.Evaluate(hit->normal, light, view) * static_cast<float>(n_dot_l / light.z());
            float* px = out.pixel(i, l * h + j);
            for (int c = 0; c < 3; ++c) px[c] += mean * t[c];
          }
        }
      }
    }
  });
  return out;
}

void AccumulateAmbientTerm(const core::Image& btf_view, const core::SamplingSet& lights, int view,
                           formats::AmbientTerm* ambient) {
  const int w = ambient->width;
  const int h = ambient->height;
  for (int l = 0; l < lights.size(); ++l) {
    const float weight = static_cast<float>(lights.direction(l).z() * lights.weight(l));
    for (int j = 0; j < h; ++j) {
      for (int i = 0; i < w; ++i) {
        const float* t = btf_view.pixel(i, l * h + j);
        float* a = ambient->values.pixel(i, view * h + j);
        for (int c = 0; c < 3; ++c) a[c] += weight * t[c];
      }
    }
  }
}

void WriteGroundTruthPackage(const MesostructureScene& scene, const GroundTruthOptions& o,
                             const formats::Calibration* calibration, const std::string& source,
                             const std::filesystem::path& out, bool replace, core::Progress::Style progress_style) {
  core::ThrowIfInvalid(o.Check(), "ground truth");
  formats::MaterialDescription d;
  d.name = scene.name();
  d.width = o.texels.width;
  d.height = o.texels.height;
  d.physical_size_mm = {o.texels.sample_size_mm, o.texels.sample_size_mm};
  d.d_max_mm = scene.d_max_mm();
  d.view_directions = o.views;
  d.light_directions = o.lights;
  d.provenance.source = source;
  d.provenance.texel_samples_per_side = o.samples_per_side;
  // The package's size limits, known before anything is computed.
  for (const std::string& problem :
       {formats::OversizeProblem(d, "MDF", false, 1), formats::OversizeProblem(d, "full BTF", true, 3)}) {
    if (!problem.empty()) throw core::Error(out.string() + ": " + problem);
  }
  // The largest things held at once: the MDF and one BTF view image (floats).
  const std::uint64_t texels = static_cast<std::uint64_t>(d.width) * d.height;
  core::CheckMemoryFor(4 * texels * (o.views.size() + 3ull * o.lights.size()),
                       "the ground truth's MDF and one BTF view at " + std::to_string(d.width) + "x" +
                           std::to_string(d.height) + " texels, " + std::to_string(o.views.size()) + " views x " +
                           std::to_string(o.lights.size()) + " lights");
  formats::MaterialPackageWriter writer(out, d, replace);

  core::Progress progress("groundtruth " + scene.name(), o.views.size() + 1, progress_style);
  writer.WriteMdf(ComputeTrueMdf(scene, o));
  progress.Advance();

  formats::AmbientTerm ambient{o.texels.width, o.texels.height, o.views,
                               core::Image(o.texels.width, o.texels.height * o.views.size(), 3)};
  for (int v = 0; v < o.views.size(); ++v) {
    const core::Image view = RenderTrueBtfView(scene, o, v);
    AccumulateAmbientTerm(view, o.lights, v, &ambient);
    writer.WriteFullBtfView(v, view);
    progress.Advance();
  }
  writer.WriteAmbientTerm(ambient);
  if (calibration != nullptr) writer.WriteCalibration(*calibration);
  writer.Commit();
}

}  // namespace mesocap::sim
