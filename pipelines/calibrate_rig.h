// `mesocap calibrate --session S`: a rig calibrated from its calibration
// session (acquisition/capture_plan.h, MakeCalibrationPlan): the cameras'
// intrinsics and distortion and their poses in the world frame the turntable
// defines, from the board on its holder tilts at the turntable's angles
// (calibration/camera_calibration.h, TurntableMotion).
//
// When the session holds white reference images, the cameras' radiometric
// gains and the lamps' intensities come from them
// (calibration/radiometric_calibration.h), with the estimated cameras.
//
// What is not calibrated from images yet: the light arc, the lamps'
// positions and the laser mounts (and the gains and intensities of a session
// without a white reference). The calibration written takes them from the rig
// description's nominal geometry (calibration/nominal_geometry.h), without
// uncertainty, and the report says so; `process mdf` still finds the laser
// planes from the capture session's own plates (MDF paper Sec. 3.2).
#pragma once

#include <filesystem>

#include "calibration/calibration_report.h"
#include "calibration/camera_calibration.h"
#include "core/error.h"

namespace mesocap::pipelines {

struct CalibrateRigOptions {
  std::filesystem::path session;
  std::filesystem::path out;  // calibration.json
  bool replace = false;
  bool cross_validate = true;
  calibration::CameraCalibrationOptions calibration;
  core::CheckResult Check() const;
};

calibration::CalibrationReport RunCalibrateRig(const CalibrateRigOptions& options);

}  // namespace mesocap::pipelines
