// A rigid transform between two named frames of the rig (docs/ARCHITECTURE.md: world,
// turntable, sample, camera:<id>, lamp:<id>, laser). It maps coordinates in
// the child frame to the parent frame: x_parent = rotation * x_child + translation.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <string>

#include "core/json_field_reader.h"

namespace mesocap::core {

struct RigidTransform {
  std::string parent_frame = "world";
  std::string child_frame = "world";
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();  // mm

  Eigen::Vector3d Apply(const Eigen::Vector3d& x_child) const { return rotation * x_child + translation; }
  RigidTransform Inverse() const;
  // (this * other) maps other.child -> this.parent; throws Error if
  // other.parent_frame != this->child_frame.
  RigidTransform Compose(const RigidTransform& other) const;
};

// JSON form (docs/FORMATS.md "Poses"): {"parent", "child", "rotation": 9
// numbers row-major, "translation_mm": 3 numbers in [-1e6, 1e6]}. The reader
// rejects a rotation that is not orthonormal with determinant +1 to within 1e-6.
nlohmann::json ToJson(const RigidTransform& t);
RigidTransform ReadRigidTransform(const JsonFieldReader& fields);

// Frame names are "world", "turntable", "sample", "laser", "light_arc",
// or "camera:<id>" / "lamp:<id>" / "laser:<id>" with a non-empty id.
bool IsValidFrameName(const std::string& name);

}  // namespace mesocap::core
