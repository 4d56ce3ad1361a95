#include "mdf/frame_plane.h"

#include <Eigen/Geometry>
#include <cmath>

namespace mesocap::mdf {

core::Plane FramePlane(const calibration::ReferenceLine& line, const core::Plane& calibrated,
                       const Eigen::Vector3d& tilt_axis, double delta_tilt_rad) {
  core::Plane plane;
  if (!line.valid || !calibrated.valid()) return plane;
  plane.normal = Eigen::AngleAxisd(delta_tilt_rad, tilt_axis.normalized()) * calibrated.normal;
  // The calibrated plane's horizontal trace is parallel to the line; keep
  // the normal's horizontal part across it (remove the tiny along-line part
  // a calibration error leaves, so the plane contains the measured line).
  const Eigen::Vector3d along(line.direction.x(), line.direction.y(), 0.0);
  plane.normal = (plane.normal - plane.normal.dot(along) * along).normalized();
  plane.offset = plane.normal.dot(Eigen::Vector3d(line.point.x(), line.point.y(), line.height));
  return plane;
}

core::Plane PlaneAtTime(const std::vector<core::Plane>& planes, double t, int max_gap) {
  if (!(t >= 0) || t > static_cast<double>(planes.size()) - 1) return {};
  const int n = static_cast<int>(planes.size());
  // The nearest valid planes at or before and at or after t, at most
  // max_gap frames apart (a dropped frame has no plane of its own).
  int i0 = static_cast<int>(std::floor(t));
  int i1 = static_cast<int>(std::ceil(t));
  while (i0 >= 0 && !planes[i0].valid()) --i0;
  while (i1 < n && !planes[i1].valid()) ++i1;
  if (i0 < 0 || i1 >= n || i1 - i0 > max_gap) return {};
  if (i0 == i1) return planes[i0];
  const double f = (t - i0) / (i1 - i0);
  const core::Plane& a = planes[i0];
  const core::Plane& b = planes[i1];
  core::Plane p;
  const Eigen::Vector3d normal = (1 - f) * a.normal + f * b.normal;
  const double norm = normal.norm();
  p.normal = normal / norm;
  p.offset = ((1 - f) * a.offset + f * b.offset) / norm;
  return p;
}

}  // namespace mesocap::mdf
