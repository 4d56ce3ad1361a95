#include "calibration/laser_plane_calibration.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
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

double AngleToReferencePlane(const core::Plane& plane) { return std::acos(std::min(1.0, std::abs(plane.normal.z()))); }

core::Plane CalibrateLaserPlane(const core::Image& lower, double lower_height_mm, const core::Image& upper,
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
    return PlaneThroughLines(detect(lower, lower_height_mm), detect(upper, upper_height_mm));
  } catch (const core::FormatError&) {
    throw;
  } catch (const core::Error& e) {
    const std::string message = e.what();
    if (message.rfind(what, 0) == 0) throw;
    throw core::Error(what + ": " + message);
  }
}

}  // namespace mesocap::calibration
