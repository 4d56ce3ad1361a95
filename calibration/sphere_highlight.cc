#include "calibration/sphere_highlight.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

namespace mesocap::calibration {

core::CheckResult SphereHighlightOptions::Check() const {
  if (!(min_peak > 0 && min_peak < 1)) return "the highlight's minimum peak must be in (0, 1)";
  if (window_radius_px < 1 || window_radius_px > 64) return "the highlight's window radius must be 1..64 pixels";
  if (!(background_fraction >= 0 && background_fraction < 1)) return "the background fraction must be in [0, 1)";
  if (!(saturation > 0 && saturation <= 1)) return "the saturation level must be in (0, 1]";
  return {};
}

std::optional<SphereHighlight> FindSphereHighlight(const core::Image& image, const SphereHighlightOptions& options) {
  core::ThrowIfInvalid(options.Check(), "sphere highlight");
  const core::Image grey = image.channels() == 1 ? image : core::ChannelMean(image);
  int bx = 0, by = 0;
  float peak = -1.0f;
  for (int y = 0; y < grey.height(); ++y) {
    for (int x = 0; x < grey.width(); ++x) {
      if (grey.at(x, y) > peak) {
        peak = grey.at(x, y);
        bx = x;
        by = y;
      }
    }
  }
  if (!(peak >= options.min_peak)) return std::nullopt;
  SphereHighlight h;
  h.peak = peak;
  const int w = options.window_radius_px;
  const double floor = options.background_fraction * peak;
  double sum = 0, sx = 0, sy = 0;
  for (int y = 0; y < grey.height(); ++y) {
    for (int x = 0; x < grey.width(); ++x) {
      const double v = grey.at(x, y);
      const bool inside = std::abs(x - bx) <= w && std::abs(y - by) <= w;
      if (!inside) {
        // Half the peak is far above any antialiased edge of this highlight.
        if (v >= 0.5 * peak && h.problem.empty()) {
          h.problem = "a second highlight at pixel (" + std::to_string(x) + ", " + std::to_string(y) + ")";
        }
        continue;
      }
      if (v >= options.saturation) ++h.saturated_pixels;
      if (v <= floor) continue;
      h.pixels.push_back({x, y, v - floor});
      sum += v - floor;
      sx += (v - floor) * x;
      sy += (v - floor) * y;
    }
  }
  h.pixel = Eigen::Vector2d(sx / sum, sy / sum);
  if (h.problem.empty() && (bx < w || by < w || bx >= grey.width() - w || by >= grey.height() - w)) {
    h.problem = "the highlight lies within " + std::to_string(w) + " pixels of the image's edge";
  }
  return h;
}

namespace {

double Angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return std::atan2(a.cross(b).norm(), a.dot(b)); }

}  // namespace

std::optional<Eigen::Vector3d> SpecularPoint(const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& eye,
                                             const Eigen::Vector3d& lamp) {
  const Eigen::Vector3d u = (eye - centre).normalized();
  const Eigen::Vector3d l = (lamp - centre).normalized();
  const double phi = Angle(u, l);
  if (phi > std::numbers::pi - 1e-9) return std::nullopt;
  Eigen::Vector3d w = l - l.dot(u) * u;
  if (w.norm() < 1e-15) return centre + radius * u;  // lamp straight behind the eye
  w.normalize();
  // f(theta) = angle(n, to eye) - angle(n, to lamp) rises from <= 0 at the
  // eye's direction to >= 0 at the lamp's.
  double lo = 0.0, hi = phi;
  for (int i = 0; i < 200 && hi - lo > 1e-13; ++i) {
    const double mid = 0.5 * (lo + hi);
    const Eigen::Vector3d n = std::cos(mid) * u + std::sin(mid) * w;
    const Eigen::Vector3d p = centre + radius * n;
    if (Angle(n, eye - p) - Angle(n, lamp - p) < 0) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  const double theta = 0.5 * (lo + hi);
  return centre + radius * (std::cos(theta) * u + std::sin(theta) * w);
}

}  // namespace mesocap::calibration
