#include "processing/laser_sweep.h"

#include <Eigen/Geometry>
#include <cmath>
#include <string>

namespace mesocap {

RigidTransform WorldFromSample(const TurntableCalibration& turntable, double angle_rad) {
  RigidTransform turn;
  turn.parent_frame = "world";
  turn.child_frame = "turntable";
  turn.rotation = Eigen::AngleAxisd(angle_rad, turntable.axis_direction.normalized()).toRotationMatrix();
  turn.translation = turntable.axis_point_mm - turn.rotation * turntable.axis_point_mm;
  RigidTransform pose = turntable.sample_pose.transform;
  pose.parent_frame = "turntable";
  return turn.Compose(pose);
}

Eigen::Vector3d LightArcPointToWorld(const LightArcCalibration& arc, double angle_rad, const Eigen::Vector3d& p) {
  const Eigen::AngleAxisd turn(angle_rad, arc.axis_direction.normalized());
  return arc.axis_point_mm + turn * (p - arc.axis_point_mm);
}

Eigen::Vector3d LightArcDirectionToWorld(const LightArcCalibration& arc, double angle_rad, const Eigen::Vector3d& d) {
  return Eigen::AngleAxisd(angle_rad, arc.axis_direction.normalized()) * d;
}

LaserMountPose MountInWorld(const Calibration& calibration, int mount, double arc_rad, double tilt_rad) {
  if (mount < 0 || mount >= static_cast<int>(calibration.laser_mounts.size())) {
    throw Error("calibration has no laser mount " + std::to_string(mount) + " (it has " +
                std::to_string(calibration.laser_mounts.size()) + ")");
  }
  const LaserMountCalibration& m = calibration.laser_mounts[mount];
  LaserMountPose pose;
  pose.source = LightArcPointToWorld(calibration.light_arc, arc_rad, m.source_mm);
  pose.tilt_axis = LightArcDirectionToWorld(calibration.light_arc, arc_rad, m.tilt_axis.normalized());
  pose.normal = LightArcDirectionToWorld(calibration.light_arc, arc_rad,
                                         Eigen::AngleAxisd(tilt_rad, m.tilt_axis.normalized()) *
                                             m.plane_normal_at_zero_tilt.normalized());
  return pose;
}

Plane CalibrateLaserPlane(const Image& lower, double lower_height_mm, const Image& upper, double upper_height_mm,
                          const CameraRays& rays, const Eigen::Vector2d& scan_direction, double outer_mm,
                          const LaserLineOptions& options, const std::string& what) {
  auto detect = [&](const Image& frame, double height) {
    PixelMask plate(static_cast<std::size_t>(rays.width()) * rays.height(), 0);
    for (int y = 0; y < rays.height(); ++y) {
      for (int x = 0; x < rays.width(); ++x) {
        Eigen::Vector3d p;
        if (IntersectHorizontalPlane(rays.centre(), rays.Ray(x, y), height, &p) && p.head<2>().norm() <= outer_mm) {
          plate[static_cast<std::size_t>(y) * rays.width() + x] = 1;
        }
      }
    }
    const ReferenceLine line = DetectLaserLine(frame, plate, rays, height, scan_direction, options);
    if (!line.valid) {
      throw Error(what + ": no laser stripe found on the plate at height " + std::to_string(height) + " mm");
    }
    return line;
  };
  try {
    return PlaneThroughLines(detect(lower, lower_height_mm), detect(upper, upper_height_mm));
  } catch (const FormatError&) {
    throw;
  } catch (const Error& e) {
    const std::string message = e.what();
    if (message.rfind(what, 0) == 0) throw;
    throw Error(what + ": " + message);
  }
}

PixelMask ReferenceRegion(const CameraRays& rays, const RigidTransform& world_from_sample, double sample_size_mm,
                          double margin_mm, double outer_mm) {
  PixelMask mask(static_cast<std::size_t>(rays.width()) * rays.height(), 0);
  const RigidTransform sample_from_world = world_from_sample.Inverse();
  const double half = 0.5 * sample_size_mm + margin_mm;
  for (int y = 0; y < rays.height(); ++y) {
    for (int x = 0; x < rays.width(); ++x) {
      Eigen::Vector3d p;
      if (!IntersectHorizontalPlane(rays.centre(), rays.Ray(x, y), 0.0, &p)) continue;
      const Eigen::Vector3d s = sample_from_world.Apply(p);
      const bool outside = std::abs(s.x()) > half || std::abs(s.y()) > half;
      if (outside && s.head<2>().norm() <= outer_mm) mask[static_cast<std::size_t>(y) * rays.width() + x] = 1;
    }
  }
  return mask;
}

LaserSweepProcessor::LaserSweepProcessor(const CameraRays& rays, SweepGeometry geometry,
                                         const LaserLineOptions& line_options,
                                         const SpaceTimeOptions& space_time_options)
    : rays_(rays),
      geometry_(std::move(geometry)),
      line_options_(line_options),
      analyzer_(rays.width(), rays.height(), static_cast<int>(geometry_.delta_tilt_rad.size()), space_time_options),
      lines_(geometry_.delta_tilt_rad.size()) {
  if (const auto problem = line_options.Check(); !problem.empty()) throw Error("laser line: " + problem);
  if (geometry_.reference_region.size() != static_cast<std::size_t>(rays.width()) * rays.height()) {
    throw Error("laser sweep: the reference region does not match the camera's image size");
  }
  if (!geometry_.calibrated_plane.valid()) throw Error("laser sweep: the calibrated laser plane is invalid");
  const Eigen::Vector2d horizontal = geometry_.calibrated_plane.normal.head<2>();
  if (horizontal.norm() < 1e-6) throw Error("laser sweep: the calibrated laser plane is horizontal");
  scan_direction_ = horizontal.normalized();
}

void LaserSweepProcessor::AddFrame(int index, const Image& frame) {
  analyzer_.AddFrame(index, frame);  // validates size and order first
  lines_[index] = DetectLaserLine(frame, geometry_.reference_region, rays_, 0.0, scan_direction_, line_options_);
}

SweepAnalysis LaserSweepProcessor::Finish() const {
  SweepAnalysis result = analyzer_.Result();
  for (std::size_t i = 0; i < lines_.size(); ++i) {
    result.planes[i] = FramePlane(lines_[i], geometry_.calibrated_plane, geometry_.tilt_axis,
                                  geometry_.delta_tilt_rad[i]);
  }
  return result;
}

}  // namespace mesocap
