// Cross-validation of a camera calibration, as mrcal reports it: the photos
// split into two disjoint halves (alternate instants), each calibrated on
// its own, and the two results' projections compared. On a turntable (a
// rig) both share the world frame, and the sample square on the reference
// plane is projected by each. Without one, each camera's frame is its own
// and a principal point's error trades against the camera's rotation, so
// (as mrcal does) the pixels over the area the board covered are
// unprojected by one half, turned by the rotation that best aligns the two
// halves' rays, and projected by the other. If the model fits and the
// uncertainty is honest, the difference is about sqrt(2) times the
// projection uncertainty; a much larger one means the model does not fit.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calibration/camera_calibration.h"

namespace mesocap::calibration {

struct CrossValidationDifference {
  std::string camera_id;
  // RMS and largest difference over a 10 x 10 grid (of the sample square's
  // points, or of pixels spanning the board's corners in the photos).
  double rms_px = 0;
  double max_px = 0;
  double rms_mm = 0;  // rms_px in mm at the compared points' distance
};

// One entry per camera, or nullopt (with `why` set) when a half has too few
// photos to calibrate on its own. The halves keep the distortion models
// `calibrated` (the whole set's calibration) chose: the figure is that
// calibration's, and no half climbs the ladder again.
std::optional<std::vector<CrossValidationDifference>> CrossValidate(
    const CalibrationBoard& board, const std::vector<CameraViews>& cameras, const CameraCalibrationOptions& options,
    const CameraCalibrationResult& calibrated, std::string* why, const TurntableMotion* motion = nullptr);

}  // namespace mesocap::calibration
