// Cross-validation of a camera calibration, as mrcal reports it: the photos
// split into two disjoint halves (alternate instants), each calibrated on
// its own, and the two results' projections compared over the area the
// board covered. If the model fits and the uncertainty is honest, the
// difference is about sqrt(2) times the projection uncertainty; a much larger
// one means the model (distortion terms, a rigid board) does not fit.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calibration/camera_calibration.h"

namespace mesocap::calibration {

struct CrossValidationDifference {
  std::string camera_id;
  // RMS and largest difference over a 10 x 10 grid of pixels spanning the
  // board's corners in the photos: a pixel unprojected by one half's
  // calibration to the working distance and projected by the other's.
  double rms_px = 0;
  double max_px = 0;
  double rms_mm = 0;  // rms_px in mm on a plane at the working distance
};

// One entry per camera, or nullopt (with `why` set) when a half has too few
// photos to calibrate on its own.
std::optional<std::vector<CrossValidationDifference>> CrossValidate(const CalibrationBoard& board,
                                                                    const std::vector<CameraViews>& cameras,
                                                                    const CameraCalibrationOptions& options,
                                                                    std::string* why);

}  // namespace mesocap::calibration
