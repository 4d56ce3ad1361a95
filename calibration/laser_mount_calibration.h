// The laser mounts on the light arc from the stripe on the two-height plates
// (MDF paper Sec. 3.2) at both ends of each laser location's sweep.
//
// A mount's plane contains its tilt axis, a line through the laser source;
// tilting by t turns the plane's normal about that axis by t
// (formats/calibration.h). Each location's plates give its plane at each tilt
// (LaserPlaneFit, per camera that sees the stripe); the planes of one mount at
// two tilts meet on its tilt axis. One Ceres problem per mount fits, in the
// light_arc frame: the axis' direction (SphereManifold), its place (a point in
// the plane across the nominal axis through the nominal source) and the angle
// of the plane at tilt 0 about the axis, to every plane of every location
// on that mount (the locations are the mount at several arc angles, brought
// into the arc's frame with the calibrated light arc). Residuals: each
// measured plane's anchor off the predicted plane, over its position sigma,
// and its normal off the predicted one, over its normal sigma. Standard
// deviations come from the Ceres covariance, scaled by the residuals'
// variance; the planes of one camera share that camera's calibration errors,
// which the covariance takes as independent, so with three or more cameras
// the spread of the fits leaving one camera out (a jackknife) is the sigma
// where it is larger.
//
// A plane far off its mount's fit (a stripe seen along itself, half hidden,
// or met by a reflection) is an outlier: found after a robust first solve,
// left out and reported.
//
// Conditioning:
// - The tilts of a sweep differ by about 2 degrees (a 26 mm sweep at 700 mm):
//   two planes that close meet on a line whose place is uncertain by about
//   (normal error x source distance) / (tilt difference), millimetres for
//   a plate normal good to 1e-5 rad. The axis' direction across the planes
//   is the weakest part; the sigmas say how weak.
// - The source's place along its tilt axis does not move any plane: it is
//   kept where the nominal geometry puts it, projected onto the fitted axis.
// - A mount seen at one tilt only gives no axis: an Error naming the mount.
// - Processing turns a location's plate plane by the tilt relative to its
//   plates about this axis (mdf/frame_plane.h): an axis error e turns the
//   frame's normal by about e x (tilt difference), 1e-5 rad for e = 0.5
//   degree over a 1-degree half sweep.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "calibration/camera_calibration.h"
#include "calibration/laser_plane_calibration.h"
#include "core/error.h"
#include "formats/calibration.h"

namespace mesocap::calibration {

// One laser plane measured on the plates: the location's mount, arc angle
// and commanded tilt, the plane in the world seen by one camera.
struct LaserPlaneObservation {
  int camera = 0;  // planes of one camera share its calibration's errors
  int mount = 0;
  double arc_rad = 0.0;
  double tilt_rad = 0.0;
  LaserPlaneFit fit;
  std::string name;  // for messages: the location, tilt and camera
};

struct LaserMountOptions {
  // Above these one-sigma uncertainties (the tilt axis' direction, degrees;
  // the source across the axis, mm) a mount's fit is too uncertain to
  // replace the rig description's nominal mount (LaserMountResult::too_uncertain).
  double max_axis_sigma_deg = 1.0;
  double max_source_sigma_mm = 5.0;
  // The robust first solve's Huber scale, and the outlier threshold, in the
  // planes' own sigmas: a plane beyond outlier_sigmas robust sigmas (the
  // residuals' median absolute value, at least 1) is left out and reported.
  double huber_sigmas = 3.0;
  double outlier_sigmas = 5.0;
  core::CheckResult Check() const;
};

struct LaserMountResult {
  // Per calibration mount: the fit, with its uncertainty (light_arc frame);
  // tilt ranges are the nominal ones.
  std::vector<formats::LaserMountCalibration> mounts;
  int planes_used = 0;
  std::vector<SetAsideImage> left_out;  // outlier planes, with why
  // RMS of the planes' anchors off the fitted planes (mm) and of their
  // normals' angles to the fitted normals (degrees).
  double position_residual_rms_mm = 0.0;
  double normal_residual_rms_deg = 0.0;
  // Why the result should not replace the nominal mounts (a sigma beyond the
  // options' limits, or none at all); empty when it may.
  std::string too_uncertain;
};

// `geometry` gives the light arc (calibrated or nominal) and the nominal
// mounts the fit starts from. Throws Error naming a mount that has planes at
// fewer than two tilts, or none.
LaserMountResult CalibrateLaserMounts(const formats::Calibration& geometry,
                                      const std::vector<LaserPlaneObservation>& planes,
                                      const LaserMountOptions& options);

}  // namespace mesocap::calibration
