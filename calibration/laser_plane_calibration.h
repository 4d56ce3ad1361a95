// The laser planes' calibration (MDF paper Sec. 3.2): each laser location's
// plane from the stripe on flat plates at two heights.
#pragma once

#include <Eigen/Core>
#include <string>

#include "calibration/camera_rays.h"
#include "calibration/laser_line.h"
#include "core/image.h"
#include "core/plane.h"

namespace mesocap::calibration {

// The plane through the stripe's lines on two horizontal plates (Sec. 3.2:
// "project the laser strip onto two planes with different heights and
// calculate the offset"). Conditioning: the plane's tilt is the height
// difference over the lines' horizontal offset, so a line error e gives an
// angle error ~ e / (h1 - h0); throws Error when the heights are closer
// than 1 mm or the lines are not parallel to within 2 degrees (a detection
// failure), or either line is invalid.
core::Plane PlaneThroughLines(const ReferenceLine& lower, const ReferenceLine& upper);

// Angle between a laser plane and the reference plane z = 0, radians in
// [0, pi/2].
double AngleToReferencePlane(const core::Plane& plane);

// The laser plane of one location from its two calibration frames, the
// stripe on flat plates at two heights (Sec. 3.2); the stripe is searched on
// the whole plate within outer_mm of the turntable axis. Throws Error when
// the stripe is not found in either frame (naming `what`).
core::Plane CalibrateLaserPlane(const core::Image& lower, double lower_height_mm, const core::Image& upper,
                                double upper_height_mm, const CameraRays& rays, const Eigen::Vector2d& scan_direction,
                                double outer_mm, const LaserLineOptions& options, const std::string& what);

}  // namespace mesocap::calibration
