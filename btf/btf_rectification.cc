#include "btf/btf_rectification.h"

#include <Eigen/SVD>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace mesocap::btf {
namespace {

// Catmull-Rom (Keys, a = -1/2) weights of the 4 pixels x0 - 1 .. x0 + 2 for
// a sample at x0 + t, t in [0, 1); they sum to 1.
std::array<double, 4> CatmullRomWeights(double t) {
  const double t2 = t * t, t3 = t2 * t;
  return {0.5 * (-t3 + 2 * t2 - t), 0.5 * (3 * t3 - 5 * t2 + 2), 0.5 * (-3 * t3 + 4 * t2 + t), 0.5 * (t3 - t2)};
}

}  // namespace

ReferencePlaneRectifier::ReferencePlaneRectifier(const formats::CameraCalibration& camera,
                                                 const calibration::CameraRays& rays,
                                                 const core::RigidTransform& world_from_sample,
                                                 const calibration::TexelGrid& grid, int max_samples_per_side)
    : width_(grid.width), height_(grid.height), image_width_(camera.width), image_height_(camera.height) {
  if (!grid.Check().empty() || max_samples_per_side < 1) throw core::Error("rectification: invalid texture grid");
  const double dx = grid.texel_width_mm(), dy = grid.texel_height_mm();
  const auto project = [&](const Eigen::Vector3d& sample_point) {
    const Eigen::Vector2d pixel = rays.Project(world_from_sample.Apply(sample_point));
    if (!pixel.allFinite()) throw core::Error("rectification: the sample is behind camera " + camera.id);
    return pixel;
  };
  first_tap_.reserve(static_cast<std::size_t>(width_) * height_ + 1);
  min_pixels_per_texel_ = std::numeric_limits<double>::infinity();
  std::vector<Tap> texel_taps;
  for (int j = 0; j < height_; ++j) {
    for (int i = 0; i < width_; ++i) {
      const Eigen::Vector3d p = grid.TexelCentre(i, j);
      // Footprint: the images of the texel's edges' midpoints.
      const Eigen::Vector2d du =
          project(p + Eigen::Vector3d(dx / 2, 0, 0)) - project(p - Eigen::Vector3d(dx / 2, 0, 0));
      const Eigen::Vector2d dv =
          project(p + Eigen::Vector3d(0, dy / 2, 0)) - project(p - Eigen::Vector3d(0, dy / 2, 0));
      Eigen::Matrix2d jacobian;
      jacobian << du, dv;
      min_pixels_per_texel_ =
          std::min(min_pixels_per_texel_, Eigen::JacobiSVD<Eigen::Matrix2d>(jacobian).singularValues()[1]);
      const double extent = std::max(du.cwiseAbs().maxCoeff(), dv.cwiseAbs().maxCoeff());
      const int n = std::clamp(static_cast<int>(std::ceil(extent - 1e-9)), 1, max_samples_per_side);
      samples_per_side_max_ = std::max(samples_per_side_max_, n);
      texel_taps.clear();
      const double w = 1.0 / (n * n);
      for (int b = 0; b < n; ++b) {
        for (int a = 0; a < n; ++a) {
          const Eigen::Vector3d q = p + Eigen::Vector3d(((a + 0.5) / n - 0.5) * dx, ((b + 0.5) / n - 0.5) * dy, 0);
          const Eigen::Vector2d uv = project(q);
          const double fx = std::floor(uv.x()), fy = std::floor(uv.y());
          const int x0 = static_cast<int>(fx), y0 = static_cast<int>(fy);
          if (!(uv.allFinite()) || x0 < 0 || y0 < 0 || x0 + 1 >= image_width_ || y0 + 1 >= image_height_) {
            throw core::Error("rectification: texel (" + std::to_string(i) + ", " + std::to_string(j) +
                              ") of the sample is outside the image of camera " + camera.id);
          }
          // The outer taps clamp to the image's edge (the sample is well
          // inside the image on any usable rig).
          const std::array<double, 4> kx = CatmullRomWeights(uv.x() - fx), ky = CatmullRomWeights(uv.y() - fy);
          for (int b4 = 0; b4 < 4; ++b4) {
            const int y = std::clamp(y0 - 1 + b4, 0, image_height_ - 1);
            for (int a4 = 0; a4 < 4; ++a4) {
              const int x = std::clamp(x0 - 1 + a4, 0, image_width_ - 1);
              texel_taps.push_back({y * image_width_ + x, static_cast<float>(w * kx[a4] * ky[b4])});
            }
          }
        }
      }
      // One tap per pixel: the footprint's samples share most of theirs.
      std::sort(texel_taps.begin(), texel_taps.end(), [](const Tap& a, const Tap& b) { return a.pixel < b.pixel; });
      first_tap_.push_back(static_cast<int>(taps_.size()));
      for (const Tap& tap : texel_taps) {
        if (taps_.size() > static_cast<std::size_t>(first_tap_.back()) && taps_.back().pixel == tap.pixel) {
          taps_.back().weight += tap.weight;
        } else {
          taps_.push_back(tap);
        }
      }
    }
  }
  first_tap_.push_back(static_cast<int>(taps_.size()));
}

core::Image ReferencePlaneRectifier::Rectify(const core::Image& image) const {
  if (image.width() != image_width_ || image.height() != image_height_) {
    throw core::Error("rectification: image is " + std::to_string(image.width()) + "x" +
                      std::to_string(image.height()) + ", the calibrated camera " + std::to_string(image_width_) + "x" +
                      std::to_string(image_height_));
  }
  const int channels = image.channels();
  core::Image out(width_, height_, channels);
  for (int t = 0; t < width_ * height_; ++t) {
    float* dst = out.data() + static_cast<std::size_t>(t) * channels;
    for (int k = first_tap_[t]; k < first_tap_[t + 1]; ++k) {
      const float* src = image.data() + static_cast<std::size_t>(taps_[k].pixel) * channels;
      for (int c = 0; c < channels; ++c) dst[c] += taps_[k].weight * src[c];
    }
  }
  return out;
}

}  // namespace mesocap::btf
