#include "calibration/laser_plane_calibration.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "core/angles.h"
#include "core/error.h"

namespace mesocap::calibration {

core::Plane PlaneThroughLines(const ReferenceLine& lower, const ReferenceLine& upper) {
  if (!lower.valid || !upper.valid)
    throw core::Error("laser plane calibration: the stripe was not found on both plates");
  if (std::abs(upper.height - lower.height) < 1.0) {
    throw core::Error("laser plane calibration: plate heights must differ by at least 1 mm");
  }
  const double cos_between = std::abs(lower.direction.dot(upper.direction));
  if (cos_between < std::cos(core::RadiansFromDegrees(2.0))) {
    throw core::Error("laser plane calibration: the stripe's lines on the two plates are not parallel");
  }
  const double sign = lower.direction.dot(upper.direction) < 0 ? -1.0 : 1.0;
  const Eigen::Vector2d dir2 = (lower.direction + sign * upper.direction).normalized();
  const Eigen::Vector3d along(dir2.x(), dir2.y(), 0.0);
  const Eigen::Vector3d p0(lower.point.x(), lower.point.y(), lower.height);
  const Eigen::Vector3d p1(upper.point.x(), upper.point.y(), upper.height);
  core::Plane plane;
  plane.normal = along.cross(p1 - p0).normalized();
  plane.offset = plane.normal.dot(0.5 * (p0 + p1));
  return plane;
}

LaserPlaneFit FitPlaneThroughLines(const ReferenceLine& lower, const ReferenceLine& upper,
                                   const Eigen::Vector3d& camera_centre) {
  LaserPlaneFit fit;
  fit.plane = PlaneThroughLines(lower, upper);
  const Eigen::Vector3d mid(0.5 * (lower.point.x() + upper.point.x()), 0.5 * (lower.point.y() + upper.point.y()),
                            0.5 * (lower.height + upper.height));
  fit.anchor = mid - fit.plane.SignedDistance(mid) * fit.plane.normal;
  // Each line moved across itself and turned by one sigma; the plane's
  // changes add in quadrature.
  double position_variance = 0, normal_variance = 0;
  for (int which = 0; which < 2; ++which) {
    for (int parameter = 0; parameter < 2; ++parameter) {
      ReferenceLine moved[2] = {lower, upper};
      ReferenceLine& line = moved[which];
      if (parameter == 0) {
        line.point += line.offset_sigma_mm * Eigen::Vector2d(-line.direction.y(), line.direction.x());
      } else {
        const double c = std::cos(line.direction_sigma_rad), s = std::sin(line.direction_sigma_rad);
        line.direction = Eigen::Vector2d(c * line.direction.x() - s * line.direction.y(),
                                         s * line.direction.x() + c * line.direction.y());
      }
      const core::Plane changed = PlaneThroughLines(moved[0], moved[1]);
      position_variance += std::pow(changed.SignedDistance(fit.anchor), 2);
      normal_variance += std::pow(std::acos(std::min(1.0, std::abs(changed.normal.dot(fit.plane.normal)))), 2);
    }
  }
  fit.position_sigma_mm = std::sqrt(position_variance);
  fit.normal_sigma_rad = std::sqrt(normal_variance);
  const Eigen::Vector3d ray = (fit.anchor - camera_centre).normalized();
  const double across = std::abs(ray.dot(fit.plane.normal));
  fit.height_sigma_mm =
      across > 0 ? fit.position_sigma_mm * std::abs(ray.z()) / across : std::numeric_limits<double>::infinity();
  return fit;
}

double AngleToReferencePlane(const core::Plane& plane) { return std::acos(std::min(1.0, std::abs(plane.normal.z()))); }

LaserPlaneFit CalibrateLaserPlane(const core::Image& lower, double lower_height_mm, const core::Image& upper,
                                  double upper_height_mm, const CameraRays& rays, const Eigen::Vector2d& scan_direction,
                                  double outer_mm, const LaserLineOptions& options, const std::string& what) {
  auto detect = [&](const core::Image& frame, double height) {
    PixelMask plate(static_cast<std::size_t>(rays.width()) * rays.height(), 0);
    for (int y = 0; y < rays.height(); ++y) {
      for (int x = 0; x < rays.width(); ++x) {
        Eigen::Vector3d p;
        if (IntersectHorizontalPlane(rays.centre(), rays.Ray(x, y), height, &p) && p.head<2>().norm() <= outer_mm) {
          plate[static_cast<std::size_t>(y) * rays.width() + x] = 1;
        }
      }
    }
    const ReferenceLine line = DetectLaserLine(frame, plate, rays, height, scan_direction, options);
    if (!line.valid) {
      throw core::Error(what + ": no laser stripe found on the plate at height " + std::to_string(height) + " mm");
    }
    return line;
  };
  try {
    return FitPlaneThroughLines(detect(lower, lower_height_mm), detect(upper, upper_height_mm), rays.centre());
  } catch (const core::FormatError&) {
    throw;
  } catch (const core::Error& e) {
    const std::string message = e.what();
    if (message.rfind(what, 0) == 0) throw;
    throw core::Error(what + ": " + message);
  }
}

}  // namespace mesocap::calibration
