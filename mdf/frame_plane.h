// The laser plane of each frame of a sweep (MDF paper Sec. 3.2): through the
// stripe's line on the reference plane, and blended between frames.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "calibration/laser_line.h"
#include "core/plane.h"

namespace mesocap::mdf {

// The plane of one frame of a sweep: through the stripe's line on the
// reference plane (z = 0), with the calibrated plane's normal turned by
// delta_tilt_rad about tilt_axis (world, unit; it lies in the plane and is
// parallel to the line, Sec. 3.1's emitter rotation). With delta 0 this is
// the paper's "all laser planes in one scan are parallel"; the commanded
// tilt removes that approximation's error (~d tan(tilt) at depth d).
// Invalid when the line is.
core::Plane FramePlane(const calibration::ReferenceLine& line, const core::Plane& calibrated,
                       const Eigen::Vector3d& tilt_axis, double delta_tilt_rad);

// The plane at fractional frame time t: normal and offset blended linearly
// between the nearest valid planes before and after t (adjacent planes
// differ by well under a degree, and the sweep is uniform in time, so a gap
// left by dropped frames or frames without a detected line is bridged).
// Invalid when t is outside the frames or the bracketing valid planes are
// more than max_gap frames apart.
core::Plane PlaneAtTime(const std::vector<core::Plane>& planes, double t, int max_gap = 4);

}  // namespace mesocap::mdf
