#include "processing/laser_plane.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>

#include "core/error.h"

namespace mesocap {

Plane PlaneThroughLines(const ReferenceLine& lower, const ReferenceLine& upper) {
  if (!lower.valid || !upper.valid) throw Error("laser plane calibration: the stripe was not found on both plates");
  if (std::abs(upper.height - lower.height) < 1.0) {
    throw Error("laser plane calibration: plate heights must differ by at least 1 mm");
  }
  const double cos_between = std::abs(lower.direction.dot(upper.direction));
  if (cos_between < std::cos(2.0 * std::numbers::pi / 180.0)) {
    throw Error("laser plane calibration: the stripe's lines on the two plates are not parallel");
  }
  const double sign = lower.direction.dot(upper.direction) < 0 ? -1.0 : 1.0;
  const Eigen::Vector2d dir2 = (lower.direction + sign * upper.direction).normalized();
  const Eigen::Vector3d along(dir2.x(), dir2.y(), 0.0);
  const Eigen::Vector3d p0(lower.point.x(), lower.point.y(), lower.height);
  const Eigen::Vector3d p1(upper.point.x(), upper.point.y(), upper.height);
  Plane plane;
  plane.normal = along.cross(p1 - p0).normalized();
  plane.offset = plane.normal.dot(0.5 * (p0 + p1));
  return plane;
}

double AngleToReferencePlane(const Plane& plane) { return std::acos(std::min(1.0, std::abs(plane.normal.z()))); }

Plane FramePlane(const ReferenceLine& line, const Plane& calibrated, const Eigen::Vector3d& tilt_axis,
                 double delta_tilt_rad) {
  Plane plane;
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

Plane PlaneAtTime(const std::vector<Plane>& planes, double t, int max_gap) {
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
  const Plane& a = planes[i0];
  const Plane& b = planes[i1];
  Plane p;
  const Eigen::Vector3d normal = (1 - f) * a.normal + f * b.normal;
  const double norm = normal.norm();
  p.normal = normal / norm;
  p.offset = ((1 - f) * a.offset + f * b.offset) / norm;
  return p;
}

nlohmann::json ToJson(const Plane& plane) {
  if (!plane.valid()) return nullptr;
  return {{"normal", {plane.normal.x(), plane.normal.y(), plane.normal.z()}}, {"offset_mm", plane.offset}};
}

Plane PlaneFromJson(const nlohmann::json& value, const std::filesystem::path& file, const std::string& field) {
  Plane plane;
  if (value.is_null()) return plane;
  try {
    const auto& n = value.at("normal");
    if (!n.is_array() || n.size() != 3) throw Error("normal must hold 3 numbers");
    plane.normal = Eigen::Vector3d(n[0].get<double>(), n[1].get<double>(), n[2].get<double>());
    plane.offset = value.at("offset_mm").get<double>();
  } catch (const std::exception& e) {
    throw FormatError(file, field, std::string("expected null or {\"normal\": [3 numbers], \"offset_mm\": number}: ") + e.what());
  }
  if (!plane.valid() || std::abs(plane.normal.norm() - 1) > 1e-6) {
    throw FormatError(file, field + ".normal", "a finite unit vector");
  }
  return plane;
}

}  // namespace mesocap
