// Laser line detection (MDF paper Sec. 3.2, Fig. 5a): the stripe in the
// reference region of a frame is a line, since the region is flat. The frame
// is Gaussian-filtered, each scanline across the stripe gives its brightest
// pixel (a candidate) when it exceeds a threshold, refined to sub-pixel by
// a three-point Gaussian fit; candidates are projected to the horizontal
// plane the stripe lies on and a robust line is fitted there (Huber, then
// least squares on the inliers within 3 robust sigmas).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "calibration/camera_rays.h"
#include "core/error.h"
#include "core/image.h"

namespace mesocap::calibration {

struct LaserLineOptions {
  double gaussian_sigma_px = 1.0;         // pre-filter (noise reduction)
  float min_peak = 0.05f;                 // candidate threshold, fraction of full scale
  int min_candidates = 8;                 // fewer: no line in this frame
  double min_inlier_tolerance_mm = 0.02;  // floor of the outlier distance

  core::CheckResult Check() const;
};

// A line on the horizontal plane z = height (world frame).
struct ReferenceLine {
  bool valid = false;
  double height = 0.0;
  Eigen::Vector2d point = Eigen::Vector2d::Zero();       // on the line, world x y
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX();  // unit
  int candidates = 0;
  int inliers = 0;
  double rms_mm = 0.0;  // of the inliers' distances to the line
  // One sigma of the line's position across itself at `point` (the inliers'
  // centroid) and of its direction, from the inliers' scatter. The
  // pre-filter correlates neighbouring scanlines' peaks, so the scatter
  // counts as fewer independent samples than scanlines. A bias common to all
  // scanlines (the stripe's profile against the pixel grid) is not in it.
  double offset_sigma_mm = 0.0;
  double direction_sigma_rad = 0.0;
};

// Pixels a detector may use (1) or not (0), row-major, width x height.
using PixelMask = std::vector<std::uint8_t>;

// Detects the stripe among the masked pixels of a 1-channel frame.
// scan_direction: world horizontal direction across the stripe (the laser
// scan direction); scanlines are image rows or columns, whichever is closer
// to its image. Throws Error when the frame, the mask and the rays disagree
// in size.
ReferenceLine DetectLaserLine(const core::Image& frame, const PixelMask& mask, const CameraRays& rays, double height,
                              const Eigen::Vector2d& scan_direction, const LaserLineOptions& options);

// Position of the peak of three samples (t0, y0), (t1, y1), (t2, y2) around
// a maximum at t1 (t0 < t1 < t2, spacing may differ where a frame was
// dropped): the vertex of the parabola through their logarithms (exact for a
// Gaussian profile, the stripe's), or through the values themselves when a
// sample is not positive; clamped to [t1 - (t1-t0)/2, t1 + (t2-t1)/2], and
// t1 itself when the samples are flat (a plateau has no vertex).
double InterpolatePeak(double t0, double y0, double t1, double y1, double t2, double y2);

}  // namespace mesocap::calibration
