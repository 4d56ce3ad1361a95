#include "mdf/displacement_merge.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "core/mdf.h"

namespace mesocap::mdf {

double TetrahedronVolume(const Eigen::Vector3d& source, const Eigen::Vector3d& camera, const Eigen::Vector3d& line_a,
                         const Eigen::Vector3d& line_b) {
  return std::abs((source - line_a).dot((camera - line_a).cross(line_b - line_a))) / 6.0;
}

double ScanWeight(const Eigen::Vector3d& source, const Eigen::Vector3d& camera, const core::Plane& plane,
                  double half_length_mm) {
  if (!plane.valid()) return 0.0;
  const Eigen::Vector3d along = plane.normal.cross(Eigen::Vector3d::UnitZ());
  if (along.norm() < 1e-9) return 0.0;
  const Eigen::Vector3d u = along.normalized() * half_length_mm;
  return TetrahedronVolume(source, camera, -u, u);
}

core::CheckResult MergeOptions::Check() const {
  if (!(outlier_texels > 0)) return "outlier_texels must be positive";
  return {};
}

MergedDisplacement MergeDisplacementImages(const std::vector<DisplacementImage>& images,
                                           const std::vector<double>& weights, double texel_mm,
                                           const MergeOptions& options) {
  if (images.empty() || images.size() != weights.size()) {
    throw core::Error("merge: need one weight per displacement image and at least one image");
  }
  const int w = images[0].width, h = images[0].height;
  double total_weight = 0;
  for (std::size_t k = 0; k < images.size(); ++k) {
    if (images[k].width != w || images[k].height != h) throw core::Error("merge: displacement images differ in size");
    if (!(weights[k] > 0) || !std::isfinite(weights[k])) throw core::Error("merge: weights must be positive");
    total_weight += weights[k];
  }
  MergedDisplacement out;
  out.image.width = w;
  out.image.height = h;
  const std::size_t n = static_cast<std::size_t>(w) * h;
  out.image.distance_mm.assign(n, std::numeric_limits<float>::quiet_NaN());
  out.confidence.assign(n, 0.0f);
  const double tolerance = options.outlier_texels * texel_mm;
  std::vector<std::pair<float, double>> samples;
  for (std::size_t p = 0; p < n; ++p) {
    samples.clear();
    for (std::size_t k = 0; k < images.size(); ++k) {
      const float d = images[k].distance_mm[p];
      if (!std::isnan(d)) samples.emplace_back(d, weights[k]);
    }
    if (samples.empty()) continue;
    std::sort(samples.begin(), samples.end());
    double half = 0;
    for (const auto& s : samples) half += s.second;
    half *= 0.5;
    double running = 0;
    float median = samples.back().first;
    for (const auto& s : samples) {
      running += s.second;
      if (running >= half) {
        median = s.first;
        break;
      }
    }
    double sum = 0, sum_weight = 0;
    if (core::IsNoHit(median)) {
      // Most of the weight saw the texel's ray reach the backing.
      for (const auto& s : samples) sum_weight += core::IsNoHit(s.first) ? s.second : 0.0;
      out.image.distance_mm[p] = core::MdfNoHit();
      out.confidence[p] = static_cast<float>(sum_weight / total_weight);
      continue;
    }
    for (const auto& s : samples) {
      if (!(std::abs(s.first - median) <= tolerance)) continue;  // no-hit votes too
      sum += s.second * s.first;
      sum_weight += s.second;
    }
    out.image.distance_mm[p] = static_cast<float>(sum / sum_weight);
    out.confidence[p] = static_cast<float>(sum_weight / total_weight);
  }
  return out;
}

}  // namespace mesocap::mdf
