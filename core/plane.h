// A plane in the world frame: the laser planes of MDF paper Sec. 3.2 (one per
// frame of a sweep, one per laser location from its calibration plates) and
// their JSON form, shared by calibration, sweep analyses and MDF processing.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>

namespace mesocap::core {

// The points x with normal . x = offset (world frame, mm); normal is unit.
// An invalid plane (no stripe found in that frame) has a NaN normal.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double offset = 0.0;

  bool valid() const { return normal.allFinite() && std::isfinite(offset); }
  double SignedDistance(const Eigen::Vector3d& x) const { return normal.dot(x) - offset; }
};

nlohmann::json ToJson(const Plane& plane);
// null (invalid) or {"normal": unit vector, "offset_mm": number in [-1e6,
// 1e6]}; throws FormatError naming the file and field.
Plane PlaneFromJson(const nlohmann::json& value, const std::filesystem::path& file, const std::string& field);

}  // namespace mesocap::core
