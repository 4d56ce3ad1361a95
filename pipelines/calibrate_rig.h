// `mesocap calibrate --session S`: a rig calibrated from its calibration
// session (acquisition/capture_plan.h, MakeCalibrationPlan): the cameras'
// intrinsics and distortion and their poses in the world frame the turntable
// defines, from the board on its holder tilts at the turntable's angles
// (calibration/camera_calibration.h, TurntableMotion).
//
// When the session holds mirror sphere images, the lamps' positions and the
// light arc's axis come from their highlights
// (calibration/light_arc_calibration.h); when it holds white reference
// images, the cameras' radiometric gains and the lamps' intensities come
// from them (calibration/radiometric_calibration.h). Both with the
// estimated cameras, the sphere first, so the radiometry sees the
// estimated lamps.
//
// What is not calibrated from images yet: the laser mounts (and what a
// session without those images lacks). The calibration written takes them
// from the rig description's nominal geometry (calibration/nominal_geometry.h),
// without uncertainty, and the report says so; `process mdf` still finds the
// laser planes from the capture session's own plates (MDF paper Sec. 3.2).
#pragma once

#include <filesystem>

#include "calibration/calibration_report.h"
#include "calibration/camera_calibration.h"
#include "calibration/light_arc_calibration.h"
#include "core/error.h"

namespace mesocap::pipelines {

struct CalibrateRigOptions {
  std::filesystem::path session;
  std::filesystem::path out;  // calibration.json
  bool replace = false;
  bool cross_validate = true;
  calibration::CameraCalibrationOptions calibration;
  // Its limits on the fit's sigmas (the sphere's size and place come from
  // the session's rig).
  calibration::LightArcOptions light_arc;
  core::CheckResult Check() const;
};

calibration::CalibrationReport RunCalibrateRig(const CalibrateRigOptions& options);

}  // namespace mesocap::pipelines
