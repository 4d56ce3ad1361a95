#include "sim/true_calibration.h"

#include <cmath>

#include "sim/camera_renderer.h"

namespace mesocap::sim {
namespace {

// world <- camera rotation for a camera at `centre` looking at the origin.
Eigen::Matrix3d LookAtOrigin(const Eigen::Vector3d& centre) {
  const Eigen::Vector3d forward = (-centre).normalized();
  // Near-vertical cameras have no horizontal "up"; use +X then.
  const Eigen::Vector3d up = std::abs(forward.z()) > 0.999 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d right = forward.cross(up).normalized();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d r;
  r.col(0) = right;
  r.col(1) = down;
  r.col(2) = forward;
  return r;
}

}  // namespace

formats::Calibration TrueCalibration(const formats::RigDescription& rig) {
  formats::Calibration c;
  for (const auto& cam : rig.cameras) {
    formats::CameraCalibration out;
    out.id = cam.id;
    out.width = cam.width;
    out.height = cam.height;
    out.intrinsics.fx = out.intrinsics.fy = cam.focal_px;
    out.intrinsics.cx = cam.principal_point_px.x();
    out.intrinsics.cy = cam.principal_point_px.y();
    out.distortion.k1 = cam.distortion[0];
    out.distortion.k2 = cam.distortion[1];
    out.distortion.p1 = cam.distortion[2];
    out.distortion.p2 = cam.distortion[3];
    out.distortion.k3 = cam.distortion[4];
    out.pose.transform.parent_frame = "world";
    out.pose.transform.child_frame = "camera:" + cam.id;
    const Eigen::Vector3d centre = calibration::CameraCentre(cam);
    out.pose.transform.rotation = LookAtOrigin(centre);
    out.pose.transform.translation = centre;
    // Every simulated camera renders with the same exact gain.
    out.radiometry =
        formats::CameraRadiometry{.signal_per_radiance_second = kSignalPerRadianceSecond, .uncertainty = {}};
    c.cameras.push_back(out);
  }
  c.turntable.sample_pose.transform.parent_frame = "turntable";
  c.turntable.sample_pose.transform.child_frame = "sample";
  for (int i = 0; i < static_cast<int>(rig.lamps.elevations_rad.size()); ++i) {
    formats::LampCalibration lamp;
    lamp.id = "lamp" + std::to_string(i);
    lamp.position_mm = calibration::LampPosition(rig.lamps, i, 0.0);
    lamp.intensity = rig.lamps.intensity;
    c.lamps.push_back(lamp);
  }
  const auto& laser = rig.laser;
  for (int m = 0; m < static_cast<int>(laser.mount_elevations_rad.size()); ++m) {
    formats::LaserMountCalibration mount;
    mount.id = "mount" + std::to_string(m);
    mount.source_mm = calibration::LaserSource(laser, {m, 0.0});
    mount.tilt_axis = calibration::LaserTiltAxis({m, 0.0});
    mount.plane_normal_at_zero_tilt = calibration::LaserPlaneNormalAtZeroTilt(laser, {m, 0.0});
    mount.tilt_range_rad = {calibration::LaserTiltForOffset(laser, m, laser.sweep_min_mm),
                            calibration::LaserTiltForOffset(laser, m, laser.sweep_max_mm)};
    c.laser_mounts.push_back(mount);
  }
  return c;
}

}  // namespace mesocap::sim
