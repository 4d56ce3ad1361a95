#include "core/rigid_transform.h"

#include <Eigen/LU>
#include <array>

#include "core/error.h"

namespace mesocap::core {
namespace {

// As a calibration's positions (docs/FORMATS.md "Poses").
constexpr double kMaxTranslationMm = 1e6;

}  // namespace

RigidTransform RigidTransform::Inverse() const {
  RigidTransform inv;
  inv.parent_frame = child_frame;
  inv.child_frame = parent_frame;
  inv.rotation = rotation.transpose();
  inv.translation = -(inv.rotation * translation);
  return inv;
}

RigidTransform RigidTransform::Compose(const RigidTransform& other) const {
  if (other.parent_frame != child_frame) {
    throw Error("cannot compose transform " + parent_frame + "<-" + child_frame + " with " + other.parent_frame + "<-" +
                other.child_frame + ": frames do not meet");
  }
  RigidTransform out;
  out.parent_frame = parent_frame;
  out.child_frame = other.child_frame;
  out.rotation = rotation * other.rotation;
  out.translation = rotation * other.translation + translation;
  return out;
}

bool IsValidFrameName(const std::string& name) {
  static const std::array<const char*, 5> kPlain = {"world", "turntable", "sample", "laser", "light_arc"};
  for (const char* p : kPlain) {
    if (name == p) return true;
  }
  for (const std::string prefix : {"camera:", "lamp:", "laser:"}) {
    if (name.size() > prefix.size() && name.compare(0, prefix.size(), prefix) == 0) return true;
  }
  return false;
}

nlohmann::json ToJson(const RigidTransform& t) {
  nlohmann::json r = nlohmann::json::array();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.push_back(t.rotation(i, j));
  }
  return {{"parent", t.parent_frame},
          {"child", t.child_frame},
          {"rotation", r},
          {"translation_mm", {t.translation.x(), t.translation.y(), t.translation.z()}}};
}

RigidTransform ReadRigidTransform(const JsonFieldReader& fields) {
  RigidTransform t;
  t.parent_frame = fields.String("parent");
  t.child_frame = fields.String("child");
  for (const char* key : {"parent", "child"}) {
    if (!IsValidFrameName(fields.String(key))) {
      fields.Fail(key,
                  "expected a frame name (world, turntable, sample, laser, light_arc, "
                  "camera:<id>, lamp:<id>, laser:<id>), got " +
                      Quoted(fields.String(key)));
    }
  }
  const auto r = fields.Numbers("rotation", 9);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) t.rotation(i, j) = r[3 * i + j];
  }
  const double orthogonality = (t.rotation * t.rotation.transpose() - Eigen::Matrix3d::Identity()).norm();
  if (orthogonality > 1e-6 || t.rotation.determinant() < 0) {
    fields.Fail("rotation", "expected a rotation matrix (orthonormal, determinant +1)");
  }
  t.translation = fields.Vector3("translation_mm", -kMaxTranslationMm, kMaxTranslationMm);
  return t;
}

}  // namespace mesocap::core
