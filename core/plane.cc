#include "core/plane.h"

#include <exception>

#include "core/error.h"

namespace mesocap::core {

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
    throw FormatError(file, field,
                      std::string("expected null or {\"normal\": [3 numbers], \"offset_mm\": number}: ") + e.what());
  }
  if (!plane.valid() || std::abs(plane.normal.norm() - 1) > 1e-6) {
    throw FormatError(file, field + ".normal", "a finite unit vector");
  }
  return plane;
}

}  // namespace mesocap::core
