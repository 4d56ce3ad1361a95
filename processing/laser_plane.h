// Laser planes (MDF paper Sec. 3.2): the plane of the laser stripe in one
// frame, its angle to the reference plane from the two-height calibration
// frames, and the per-frame plane built from the stripe's line on the
// reference plane.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

#include "processing/laser_line.h"

namespace mesocap {

// The points x with normal . x = offset (world frame, mm); normal is unit.
// An invalid plane (no stripe found in that frame) has a NaN normal.
struct Plane {
  Eigen::Vector3d normal = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double offset = 0.0;

  bool valid() const { return normal.allFinite() && std::isfinite(offset); }
  double SignedDistance(const Eigen::Vector3d& x) const { return normal.dot(x) - offset; }
};

// The plane through the stripe's lines on two horizontal plates (Sec. 3.2:
// "project the laser strip onto two planes with different heights and
// calculate the offset"). Conditioning: the plane's tilt is the height
// difference over the lines' horizontal offset, so a line error e gives an
// angle error ~ e / (h1 - h0); throws Error when the heights are closer
// than 1 mm or the lines are not parallel to within 2 degrees (a detection
// failure), or either line is invalid.
Plane PlaneThroughLines(const ReferenceLine& lower, const ReferenceLine& upper);

// Angle between a laser plane and the reference plane z = 0, radians in
// [0, pi/2].
double AngleToReferencePlane(const Plane& plane);

// The plane of one frame of a sweep: through the stripe's line on the
// reference plane (z = 0), with the calibrated plane's normal turned by
// delta_tilt_rad about tilt_axis (world, unit; it lies in the plane and is
// parallel to the line, Sec. 3.1's emitter rotation). With delta 0 this is
// the paper's "all laser planes in one scan are parallel"; the commanded
// tilt removes that approximation's error (~d tan(tilt) at depth d).
// Invalid when the line is.
Plane FramePlane(const ReferenceLine& line, const Plane& calibrated, const Eigen::Vector3d& tilt_axis,
                 double delta_tilt_rad);

// The plane at fractional frame time t: normal and offset blended linearly
// between the nearest valid planes before and after t (adjacent planes
// differ by well under a degree, and the sweep is uniform in time, so a gap
// left by dropped frames or frames without a detected line is bridged).
// Invalid when t is outside the frames or the bracketing valid planes are
// more than max_gap frames apart.
Plane PlaneAtTime(const std::vector<Plane>& planes, double t, int max_gap = 4);

nlohmann::json ToJson(const Plane& plane);
// null (invalid) or a plane; throws FormatError naming the file and field.
Plane PlaneFromJson(const nlohmann::json& value, const std::filesystem::path& file, const std::string& field);

}  // namespace mesocap
