// What a calibration reports to its user and to scripts (`mesocap calibrate
// --json`): per camera its fit, parameters with one-sigma uncertainties,
// photos set aside and why, projection uncertainty and cross-validation; the
// cameras' relative poses; the warnings. The names are the CLI's contract
// (docs/FORMATS.md "Calibration report").
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibration/camera_calibration.h"
#include "calibration/cross_validation.h"
#include "calibration/laser_mount_calibration.h"
#include "calibration/light_arc_calibration.h"
#include "calibration/radiometric_calibration.h"

namespace mesocap::calibration {

struct CalibrationReport {
  std::string board;  // the board's spec
  CameraCalibrationResult cameras;
  // Per camera, as the cameras; absent with the reason when the halves could
  // not be calibrated on their own.
  std::optional<std::vector<CrossValidationDifference>> cross_validation;
  std::string cross_validation_skipped;
  // A rig's calibration with a white reference: the cameras' gains (in the
  // cameras' order) and the lamps' intensities.
  std::optional<RadiometryResult> radiometry;
  // A rig's calibration with mirror sphere images: the light arc's axis and
  // the lamps' positions.
  std::optional<LightArcResult> light_arc;
  // A rig's calibration with laser plates at two tilts: the laser mounts,
  // and the plates' images left out (one camera's pair of plates at one
  // location and tilt): no stripe found, or an outlier plane.
  std::optional<LaserMountResult> laser_mounts;
  std::vector<SetAsideImage> laser_plates_left_out;
  // A rig's calibration: the parts it took from the rig description's
  // nominal geometry, not from images (empty for cameras alone).
  std::string nominal_parts;
};

nlohmann::json ToJson(const CalibrationReport& report);
// The same as readable tables, one line per camera and per pair.
std::string FormatCalibrationReport(const CalibrationReport& report);

}  // namespace mesocap::calibration
