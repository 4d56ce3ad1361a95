#include "core/plane.h"

#include <cmath>

#include "core/error.h"
#include "core/json_field_reader.h"

namespace mesocap::core {
namespace {

constexpr double kUnitTolerance = 1e-6;
// As a calibration's positions.
constexpr double kMaxOffsetMm = 1e6;

}  // namespace

nlohmann::json ToJson(const Plane& plane) {
  if (!plane.valid()) return nullptr;
  return {{"normal", {plane.normal.x(), plane.normal.y(), plane.normal.z()}}, {"offset_mm", plane.offset}};
}

Plane PlaneFromJson(const nlohmann::json& value, const std::filesystem::path& file, const std::string& field) {
  Plane plane;
  if (value.is_null()) return plane;
  if (!value.is_object()) {
    throw FormatError(file, field,
                      "expected null or {\"normal\": [3 numbers], \"offset_mm\": number}, got " + JsonExcerpt(value));
  }
  const JsonFieldReader fields(value, file, field);
  fields.RejectUnknownMembers({"normal", "offset_mm"});
  plane.normal = fields.Vector3("normal", -1.0 - kUnitTolerance, 1.0 + kUnitTolerance);
  plane.offset = fields.Number("offset_mm", -kMaxOffsetMm, kMaxOffsetMm);
  if (std::abs(plane.normal.norm() - 1) > kUnitTolerance) fields.Fail("normal", "expected a unit vector");
  return plane;
}

}  // namespace mesocap::core
