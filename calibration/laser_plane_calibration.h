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

// A laser plane with its uncertainty from the two lines' scatter (one sigma).
struct LaserPlaneFit {
  core::Plane plane;
  Eigen::Vector3d anchor = Eigen::Vector3d::Zero();  // on the plane, between the two lines' centroids
  double position_sigma_mm = 0.0;                    // of the plane along its normal at `anchor`
  double normal_sigma_rad = 0.0;                     // of the normal's direction
  // Of a height triangulated at `anchor` by the camera that saw the plates:
  // the position error along that camera's ray, projected on z. Grows as
  // the ray runs parallel to the plane (grazing), infinite on it.
  double height_sigma_mm = 0.0;
};

// PlaneThroughLines with the sigmas each line's offset and direction give
// the plane (first order, the lines independent); `camera_centre` is the
// camera whose rays the height sigma follows.
LaserPlaneFit FitPlaneThroughLines(const ReferenceLine& lower, const ReferenceLine& upper,
                                   const Eigen::Vector3d& camera_centre);

// Angle between a laser plane and the reference plane z = 0, radians in
// [0, pi/2].
double AngleToReferencePlane(const core::Plane& plane);

// The laser plane of one location from its two calibration frames, the
// stripe on flat plates at two heights (Sec. 3.2); the stripe is searched on
// the whole plate within outer_mm of the turntable axis. Throws Error when
// the stripe is not found in either frame (naming `what`).
LaserPlaneFit CalibrateLaserPlane(const core::Image& lower, double lower_height_mm, const core::Image& upper,
                                  double upper_height_mm, const CameraRays& rays, const Eigen::Vector2d& scan_direction,
                                  double outer_mm, const LaserLineOptions& options, const std::string& what);

}  // namespace mesocap::calibration
