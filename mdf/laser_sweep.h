// One laser scan image sequence {I_v,l(x, y, t_i)} of MDF paper Sec. 3.2,
// processed as its frames arrive: each frame's stripe line in the reference
// region gives that frame's laser plane, and the frame feeds the space-time
// analysis. The capture daemon and `mesocap process mdf` share this.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "calibration/camera_rays.h"
#include "calibration/laser_line.h"
#include "core/plane.h"
#include "core/rigid_transform.h"
#include "formats/calibration.h"
#include "formats/sweep_analysis.h"
#include "mdf/space_time_analyzer.h"

namespace mesocap::mdf {

// The reference region (Sec. 3.2): pixels whose ray meets the turntable
// plane outside the sample's bounding square grown by margin_mm and within
// outer_mm of the centre, i.e. that see only the flat turntable.
calibration::PixelMask ReferenceRegion(const calibration::CameraRays& rays,
                                       const core::RigidTransform& world_from_sample, double sample_size_mm,
                                       double margin_mm, double outer_mm);

struct SweepGeometry {
  calibration::PixelMask reference_region;
  core::Plane calibrated_plane;                          // the location's plane at the calibration tilt
  Eigen::Vector3d tilt_axis = Eigen::Vector3d::UnitY();  // world, unit
  // Per frame: its commanded tilt minus the calibration tilt (radians).
  std::vector<double> delta_tilt_rad;
};

class LaserSweepProcessor {
 public:
  // Keeps a reference to `rays`. Throws Error on bad options or a mask or
  // tilt list that does not fit.
  LaserSweepProcessor(const calibration::CameraRays& rays, SweepGeometry geometry,
                      const calibration::LaserLineOptions& line_options, const SpaceTimeOptions& space_time_options);

  // Frame `index` (1 channel); skipped indices are dropped frames.
  void AddFrame(int index, const core::Image& frame);
  // The space-time result with every frame's plane (invalid for dropped
  // frames and frames whose stripe line was not found).
  formats::SweepAnalysis Finish() const;
  const calibration::ReferenceLine& line(int index) const { return lines_[index]; }

 private:
  const calibration::CameraRays& rays_;
  SweepGeometry geometry_;
  Eigen::Vector2d scan_direction_;
  calibration::LaserLineOptions line_options_;
  SpaceTimeAnalyzer analyzer_;
  std::vector<calibration::ReferenceLine> lines_;
};

}  // namespace mesocap::mdf
