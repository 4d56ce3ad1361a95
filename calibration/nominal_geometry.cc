#include "calibration/nominal_geometry.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <vector>

namespace mesocap::calibration {

Eigen::Vector3d CameraCentre(const formats::CameraDescription& c) {
  return c.distance_mm * Eigen::Vector3d(std::cos(c.elevation_rad) * std::cos(c.azimuth_rad),
                                         std::cos(c.elevation_rad) * std::sin(c.azimuth_rad),
                                         std::sin(c.elevation_rad));
}

Eigen::Vector3d LampPosition(const formats::LampBankDescription& lamps, int lamp, double arc_angle_rad) {
  const double e = lamps.elevations_rad.at(lamp);
  return lamps.distance_mm *
         Eigen::Vector3d(std::cos(e) * std::cos(arc_angle_rad), std::cos(e) * std::sin(arc_angle_rad), std::sin(e));
}

Eigen::Vector3d LaserSource(const formats::LaserDescription& laser, const formats::LaserLocation& location) {
  const double e = laser.mount_elevations_rad.at(location.mount);
  const double a = location.arc_angle_rad;
  return laser.distance_mm * Eigen::Vector3d(std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e));
}

Eigen::Vector3d LaserTiltAxis(const formats::LaserLocation& location) {
  return Eigen::AngleAxisd(location.arc_angle_rad, Eigen::Vector3d::UnitZ()) * Eigen::Vector3d::UnitY();
}

Eigen::Vector3d LaserPlaneNormalAtZeroTilt(const formats::LaserDescription& laser,
                                           const formats::LaserLocation& location) {
  return LaserTiltAxis(location).cross(-LaserSource(laser, location)).normalized();
}

namespace {

// Adds the direction of `world_position` seen from the origin, in the sample
// frame of turntable angle `turntable_rad`, unless already present.
void AddSampleFrameDirection(const Eigen::Vector3d& world_position, double turntable_rad,
                             std::vector<core::SphericalAngles>* out) {
  core::SphericalAngles a = core::AnglesFromDirection(world_position);
  a.phi = std::remainder(a.phi - turntable_rad, 2 * std::numbers::pi);
  if (a.phi < 0) a.phi += 2 * std::numbers::pi;
  for (const auto& b : *out) {
    const double dphi = std::abs(std::remainder(a.phi - b.phi, 2 * std::numbers::pi));
    if (std::abs(a.theta - b.theta) < 1e-9 && dphi < 1e-9) return;
  }
  out->push_back(a);
}

}  // namespace

core::SamplingSet ViewDirections(const formats::RigDescription& rig) {
  std::vector<core::SphericalAngles> angles;
  for (double t : rig.turntable.angles_rad) {
    for (const auto& c : rig.cameras) AddSampleFrameDirection(CameraCentre(c), t, &angles);
  }
  return core::SamplingSet::FromAngles(rig.name + "-views", angles);
}

core::SamplingSet LightDirections(const formats::RigDescription& rig) {
  std::vector<core::SphericalAngles> angles;
  for (double t : rig.turntable.angles_rad) {
    for (double a : rig.light_arc.angles_rad) {
      for (int l = 0; l < static_cast<int>(rig.lamps.elevations_rad.size()); ++l) {
        AddSampleFrameDirection(LampPosition(rig.lamps, l, a), t, &angles);
      }
    }
  }
  return core::SamplingSet::FromAngles(rig.name + "-lights", angles);
}

double LaserTiltForOffset(const formats::LaserDescription& laser, int mount, double offset_mm) {
  // In the vertical plane through the source: the source is at horizontal
  // distance r and height h; the stripe at horizontal distance r + offset.
  const double e = laser.mount_elevations_rad.at(mount);
  const double r = laser.distance_mm * std::cos(e);
  const double h = laser.distance_mm * std::sin(e);
  return std::atan2(r + offset_mm, h) - std::atan2(r, h);
}

double LaserRaySine(const formats::RigDescription& rig, int camera, int location) {
  const Eigen::Vector3d normal = LaserPlaneNormalAtZeroTilt(rig.laser, rig.laser.locations.at(location));
  return std::abs(normal.dot(CameraCentre(rig.cameras.at(camera)).normalized()));
}

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

formats::Calibration NominalCalibration(const formats::RigDescription& rig) {
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
    const Eigen::Vector3d centre = CameraCentre(cam);
    out.pose.transform.rotation = LookAtOrigin(centre);
    out.pose.transform.translation = centre;
    c.cameras.push_back(out);
  }
  c.turntable.sample_pose.transform.parent_frame = "turntable";
  c.turntable.sample_pose.transform.child_frame = "sample";
  for (int i = 0; i < static_cast<int>(rig.lamps.elevations_rad.size()); ++i) {
    formats::LampCalibration lamp;
    lamp.id = "lamp" + std::to_string(i);
    lamp.position_mm = LampPosition(rig.lamps, i, 0.0);
    lamp.intensity = rig.lamps.intensity;
    c.lamps.push_back(lamp);
  }
  const auto& laser = rig.laser;
  for (int m = 0; m < static_cast<int>(laser.mount_elevations_rad.size()); ++m) {
    formats::LaserMountCalibration mount;
    mount.id = "mount" + std::to_string(m);
    mount.source_mm = LaserSource(laser, {m, 0.0});
    mount.tilt_axis = LaserTiltAxis({m, 0.0});
    mount.plane_normal_at_zero_tilt = LaserPlaneNormalAtZeroTilt(laser, {m, 0.0});
    mount.tilt_range_rad = {LaserTiltForOffset(laser, m, laser.sweep_min_mm),
                            LaserTiltForOffset(laser, m, laser.sweep_max_mm)};
    c.laser_mounts.push_back(mount);
  }
  return c;
}

}  // namespace mesocap::calibration
