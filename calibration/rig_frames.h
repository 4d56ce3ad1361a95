// The rig's moving frames (docs/ARCHITECTURE.md "Conventions of the data"): the sample
// in the world at a turntable angle, the light arc's frame at an arc angle,
// and the laser mounts on the arc, all from a calibration.
#pragma once

#include <Eigen/Core>

#include "core/rigid_transform.h"
#include "formats/calibration.h"

namespace mesocap::calibration {

// world <- sample with the turntable at `angle_rad`: the sample pose, then
// the rotation about the calibrated turntable axis.
core::RigidTransform WorldFromSample(const formats::TurntableCalibration& turntable, double angle_rad);
// A light-arc-frame point or direction in the world with the arc at angle_rad.
Eigen::Vector3d LightArcPointToWorld(const formats::LightArcCalibration& arc, double angle_rad,
                                     const Eigen::Vector3d& p);
Eigen::Vector3d LightArcDirectionToWorld(const formats::LightArcCalibration& arc, double angle_rad,
                                         const Eigen::Vector3d& d);

// A laser mount at a light-arc angle and emitter tilt, in the world frame
// (formats/calibration.h: the tilt turns the plane's normal about tilt_axis).
struct LaserMountPose {
  Eigen::Vector3d source = Eigen::Vector3d::Zero();
  Eigen::Vector3d tilt_axis = Eigen::Vector3d::UnitY();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();  // of the nominal plane
};
// Throws Error when the calibration has no such mount.
LaserMountPose MountInWorld(const formats::Calibration& calibration, int mount, double arc_rad, double tilt_rad);

}  // namespace mesocap::calibration
