#include "calibration/rig_frames.h"

#include <Eigen/Geometry>
#include <cmath>
#include <string>

#include "core/error.h"

namespace mesocap::calibration {

core::RigidTransform WorldFromSample(const formats::TurntableCalibration& turntable, double angle_rad) {
  core::RigidTransform turn;
  turn.parent_frame = "world";
  turn.child_frame = "turntable";
  turn.rotation = Eigen::AngleAxisd(angle_rad, turntable.axis_direction.normalized()).toRotationMatrix();
  turn.translation = turntable.axis_point_mm - turn.rotation * turntable.axis_point_mm;
  core::RigidTransform pose = turntable.sample_pose.transform;
  pose.parent_frame = "turntable";
  return turn.Compose(pose);
}

Eigen::Vector3d LightArcPointToWorld(const formats::LightArcCalibration& arc, double angle_rad,
                                     const Eigen::Vector3d& p) {
  const Eigen::AngleAxisd turn(angle_rad, arc.axis_direction.normalized());
  return arc.axis_point_mm + turn * (p - arc.axis_point_mm);
}

Eigen::Vector3d LightArcDirectionToWorld(const formats::LightArcCalibration& arc, double angle_rad,
                                         const Eigen::Vector3d& d) {
  return Eigen::AngleAxisd(angle_rad, arc.axis_direction.normalized()) * d;
}

LaserMountPose MountInWorld(const formats::Calibration& calibration, int mount, double arc_rad, double tilt_rad) {
  if (mount < 0 || mount >= static_cast<int>(calibration.laser_mounts.size())) {
    throw core::Error("calibration has no laser mount " + std::to_string(mount) + " (it has " +
                      std::to_string(calibration.laser_mounts.size()) + ")");
  }
  const formats::LaserMountCalibration& m = calibration.laser_mounts[mount];
  LaserMountPose pose;
  pose.source = LightArcPointToWorld(calibration.light_arc, arc_rad, m.source_mm);
  pose.tilt_axis = LightArcDirectionToWorld(calibration.light_arc, arc_rad, m.tilt_axis.normalized());
  pose.normal = LightArcDirectionToWorld(
      calibration.light_arc, arc_rad,
      Eigen::AngleAxisd(tilt_rad, m.tilt_axis.normalized()) * m.plane_normal_at_zero_tilt.normalized());
  return pose;
}

}  // namespace mesocap::calibration
