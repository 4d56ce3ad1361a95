// `mesocap calibrate --session S`: a rig calibrated from its calibration
// session (acquisition/capture_plan.h, MakeCalibrationPlan): the cameras'
// intrinsics and distortion and their poses in the world frame the turntable
// defines, from the board on its holder tilts at the turntable's angles
// (calibration/camera_calibration.h, TurntableMotion).
//
// When the session holds mirror sphere images, the lamps' positions and the
// light arc's axis come from their highlights
// (calibration/light_arc_calibration.h); when it holds the laser's plates at
// both ends of each sweep, the laser mounts come from the planes they give
// (calibration/laser_mount_calibration.h); when it holds white reference
// images, the cameras' radiometric gains and the lamps' intensities come
// from them (calibration/radiometric_calibration.h). All with the estimated
// cameras, the sphere first, so the mounts sit on the estimated arc and the
// radiometry sees the estimated lamps.
//
// A part the session has no images for, or whose fit is too uncertain, is
// written from the rig description's nominal geometry
// (calibration/nominal_geometry.h) without uncertainty, and the report says
// so. `process mdf` still finds each capture's laser planes from that
// session's own plates (MDF paper Sec. 3.2); it takes the mounts' tilt axes
// from the calibration.
#pragma once

#include <filesystem>

#include "calibration/calibration_report.h"
#include "calibration/camera_calibration.h"
#include "calibration/laser_mount_calibration.h"
#include "calibration/light_arc_calibration.h"
#include "core/error.h"

namespace mesocap::pipelines {

struct CalibrateRigOptions {
  std::filesystem::path session;
  std::filesystem::path out;  // calibration.json
  bool replace = false;
  bool cross_validate = true;
  // Every distortion term by default: on the simulated rigs the full model
  // takes up a systematic error of the board's corners that the ladder's
  // simpler models leave to the laser mounts' and the MDF's fits (`--distortion
  // auto` chooses as `calibrate camera` does).
  calibration::CameraCalibrationOptions calibration = {.distortion_models = {calibration::DistortionModel::kFull}};
  // Its limits on the fit's sigmas (the sphere's size and place come from
  // the session's rig).
  calibration::LightArcOptions light_arc;
  calibration::LaserMountOptions laser_mounts;
  core::CheckResult Check() const;
};

calibration::CalibrationReport RunCalibrateRig(const CalibrateRigOptions& options);

}  // namespace mesocap::pipelines
