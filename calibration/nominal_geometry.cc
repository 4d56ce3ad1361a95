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

}  // namespace mesocap::calibration
