#include "mdf/laser_sweep.h"
#include "formats/sweep_analysis.h"
#include "mdf/frame_plane.h"

#include <Eigen/Geometry>
#include <cmath>
#include <string>

namespace mesocap::mdf {

calibration::PixelMask ReferenceRegion(const calibration::CameraRays& rays,
                                       const core::RigidTransform& world_from_sample, double sample_size_mm,
                                       double margin_mm, double outer_mm) {
  calibration::PixelMask mask(static_cast<std::size_t>(rays.width()) * rays.height(), 0);
  const core::RigidTransform sample_from_world = world_from_sample.Inverse();
  const double half = 0.5 * sample_size_mm + margin_mm;
  for (int y = 0; y < rays.height(); ++y) {
    for (int x = 0; x < rays.width(); ++x) {
      Eigen::Vector3d p;
      if (!calibration::IntersectHorizontalPlane(rays.centre(), rays.Ray(x, y), 0.0, &p)) continue;
      const Eigen::Vector3d s = sample_from_world.Apply(p);
      const bool outside = std::abs(s.x()) > half || std::abs(s.y()) > half;
      if (outside && s.head<2>().norm() <= outer_mm) mask[static_cast<std::size_t>(y) * rays.width() + x] = 1;
    }
  }
  return mask;
}

LaserSweepProcessor::LaserSweepProcessor(const calibration::CameraRays& rays, SweepGeometry geometry,
                                         const calibration::LaserLineOptions& line_options,
                                         const SpaceTimeOptions& space_time_options)
    : rays_(rays),
      geometry_(std::move(geometry)),
      line_options_(line_options),
      analyzer_(rays.width(), rays.height(), static_cast<int>(geometry_.delta_tilt_rad.size()), space_time_options),
      lines_(geometry_.delta_tilt_rad.size()) {
  core::ThrowIfInvalid(line_options.Check(), "laser line");
  if (geometry_.reference_region.size() != static_cast<std::size_t>(rays.width()) * rays.height()) {
    throw core::Error("laser sweep: the reference region does not match the camera's image size");
  }
  if (!geometry_.calibrated_plane.valid()) throw core::Error("laser sweep: the calibrated laser plane is invalid");
  const Eigen::Vector2d horizontal = geometry_.calibrated_plane.normal.head<2>();
  if (horizontal.norm() < 1e-6) throw core::Error("laser sweep: the calibrated laser plane is horizontal");
  scan_direction_ = horizontal.normalized();
}

void LaserSweepProcessor::AddFrame(int index, const core::Image& frame) {
  analyzer_.AddFrame(index, frame);  // validates size and order first
  lines_[index] =
      calibration::DetectLaserLine(frame, geometry_.reference_region, rays_, 0.0, scan_direction_, line_options_);
}

formats::SweepAnalysis LaserSweepProcessor::Finish() const {
  formats::SweepAnalysis result = analyzer_.Result();
  for (std::size_t i = 0; i < lines_.size(); ++i) {
    result.planes[i] =
        FramePlane(lines_[i], geometry_.calibrated_plane, geometry_.tilt_axis, geometry_.delta_tilt_rad[i]);
  }
  return result;
}

}  // namespace mesocap::mdf
