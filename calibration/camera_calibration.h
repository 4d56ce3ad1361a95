// Cameras calibrated jointly from photos of a planar board: each camera's
// intrinsics and Brown-Conrady distortion (k1 k2 p1 p2 k3), every camera's
// pose relative to the first, and the board's pose at each instant, in one
// Ceres problem over every detected corner (Zhang's method, through
// cv::calibrateCamera, gives the start). Photos with the same instant index
// were taken at the same moment by different cameras.
//
// Outliers are found, set aside and reported, never dropped silently: a
// photo whose board is blurred or saturated (BoardCornerDetector::Quality),
// corners whose residual is far beyond the others' (a robust first solve with
// a Huber loss), and photos whose corners fit much worse than the rest.
//
// Uncertainty (mrcal's and Ceres' reading): the final solve is least squares
// on the inliers; the parameters' covariance is (J^T J)^-1 at the solution,
// scaled by the residual variance measured there, sigma^2 = |r|^2 / (m - n).
// Conditioning: with every view nearly fronto-parallel the focal length and
// the board's distance trade off, J^T J is near singular and the focal
// length's sigma grows; a warning says so rather than a confident value.
//
// Only the distortion terms the photos determine are estimated. Each camera
// has a ladder of models: none, k1, k1 k2, k1 k2 p1 p2 k3 (the terms a model
// leaves out are held at zero). Every rung is solved; the camera starts at
// the richest and steps down from rung r + 1 to rung r while both hold:
//  - the fit does not need the terms r + 1 adds: rung r's AIC (Akaike's
//    criterion with the noise known, RSS / sigma^2 + 2 k: RSS the camera's
//    sum of squared corner residuals, k its distortion terms, sigma^2 the
//    richest rung's residual variance) is not above rung r + 1's, or every
//    added term is undetermined there (its sigma above its magnitude);
//  - leaving them out moves none of fx, fy, cx, cy by more than its sigma
//    under rung r + 1: a decentering term (p1 p2) that barely changes the
//    fit may still hold the principal point, and leaving it out would make
//    a confident wrong one.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calibration/board_corner_detector.h"
#include "calibration/calibration_board.h"
#include "core/error.h"
#include "core/rigid_transform.h"
#include "formats/calibration.h"

namespace mesocap::calibration {

// The distortion terms a model estimates, fewest first; the others are zero.
enum class DistortionModel { kNone, kK1, kK1K2, kFull };
inline constexpr DistortionModel kDistortionLadder[] = {DistortionModel::kNone, DistortionModel::kK1,
                                                        DistortionModel::kK1K2, DistortionModel::kFull};
// "none", "k1", "k1 k2", "k1 k2 p1 p2 k3"
const char* ToString(DistortionModel model);
// 0, 1, 2, 5: the model estimates OpenCV's first TermCount of k1 k2 p1 p2 k3.
int TermCount(DistortionModel model);

struct CameraCalibrationOptions {
  // A view needs this many corners to be used (6 is the least Zhang's
  // method and a pose take with margin).
  int min_corners_per_view = 6;
  int min_views_per_camera = 3;
  // Huber loss scale of the robust first solve, pixels.
  double huber_px = 1.0;
  // A corner is an outlier beyond this many robust sigmas of the corners'
  // residuals; a photo is, when its RMS exceeds this many times the median
  // photo's (and 0.5 px).
  double outlier_corner_sigmas = 5.0;
  double outlier_image_ratio = 3.0;
  // Photos are set aside when the board's edges are wider than this (blur)
  // or more of its pixels than this are at full scale (saturation).
  double max_edge_width_px = 3.0;
  double max_saturated_fraction = 0.02;
  // The board as given does not fit the photos when the inliers' RMS exceeds
  // this, or more than max_outlier_fraction of the corners are outliers.
  double max_rms_px = 2.0;
  double max_outlier_fraction = 0.3;
  // A relative focal-length sigma above this gets a warning (poorly observed).
  double warn_relative_focal_sigma = 0.005;
  // Empty: each camera's model chosen by the ladder (above). One: that
  // model for every camera; else one per camera.
  std::vector<DistortionModel> distortion_models;
  core::CheckResult Check() const;
};

// One camera's photos: the board's detection in each (empty when not seen)
// and its quality, indexed by instant; `names` says what to call them in
// reports (file names).
struct CameraViews {
  std::string id;
  int width = 0, height = 0;
  std::vector<std::string> names;
  std::vector<BoardDetection> detections;
  std::vector<DetectionQuality> qualities;  // empty: not measured
};

// A rig's calibration photos: the board on a holder on the turntable, the
// holder at one of several tilts (an operator's step), the turntable turned
// by the stages. The board's pose at each instant then follows from the
// holder's and the angle, and the photos give the turntable's axis: the
// world frame becomes the turntable frame at angle 0 (docs/ARCHITECTURE.md), with z
// along the axis, the origin on the axis in the reference plane (the first
// holder's board surface lies board_height_mm above it) and x along that
// board's x axis, which sets the sample frame's orientation.
struct TurntableMotion {
  std::vector<int> holder;        // per instant: the holder tilt, 0 first
  std::vector<double> angle_rad;  // per instant: the turntable's angle
  double board_height_mm = 0;
  double sample_size_mm = 0;  // the sample square's side: what cross-validation compares
  core::CheckResult Check(std::size_t instants) const;
};

// Fills views->detections and ->qualities from the photos `read(i)` gives for
// instants 0..names.size()-1 (nullopt: the camera took none then), read and
// detected in parallel. The first Error a read throws is thrown again.
void DetectBoardInPhotos(const BoardCornerDetector& detector,
                         const std::function<std::optional<core::Image>(std::size_t)>& read, CameraViews* views);

struct SetAsideImage {
  std::string name;
  std::string reason;
};

// One rung of a camera's distortion ladder, on the same inlier corners.
struct DistortionRung {
  DistortionModel model = DistortionModel::kFull;
  double rms_px = 0;
  double aic = 0;
};

struct CalibratedCamera {
  formats::CameraCalibration calibration;  // pose: reference <- camera, uncertainties filled
  int images_used = 0;
  int corners_used = 0;
  int outlier_corners = 0;
  std::vector<SetAsideImage> outlier_images;
  std::vector<SetAsideImage> unused_images;  // board not found or too few corners
  double rms_px = 0;
  // One sigma, pixels: how far the image of a point at the working distance
  // on the optical axis may be from where this calibration projects it,
  // from the intrinsics' covariance (largest axis of the 2D ellipse).
  double projection_uncertainty_px = 0;
  double working_distance_mm = 0;  // median distance of the board's corners
  DistortionModel distortion_model = DistortionModel::kFull;
  std::vector<DistortionRung> distortion_ladder;  // fewest terms first; empty: the model was given
  // Estimated terms whose sigma exceeds their magnitude ("k1", "p2", ...).
  std::vector<std::string> undetermined_terms;
};

// Camera `to` relative to camera `from`: from <- to.
struct RelativePose {
  std::string from, to;
  Eigen::Vector3d rotation_deg = Eigen::Vector3d::Zero();  // axis * angle
  Eigen::Vector3d translation_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d rotation_std_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d translation_std_mm = Eigen::Vector3d::Zero();
  bool has_std = false;  // no covariance, or a rig (where both poses are free in the world)
};

struct CameraCalibrationResult {
  std::vector<CalibratedCamera> cameras;     // in the order given; the first is the reference
  std::vector<RelativePose> relative_poses;  // each camera after the first, from the first
  double residual_sigma_px = 0;              // measured, per coordinate
  std::vector<std::string> warnings;
  // With a TurntableMotion: turntable <- board on each holder.
  std::vector<core::RigidTransform> holder_poses;
};

// Throws Error naming the camera (never sees the board, too few views, no
// photo shared with the other cameras) or the residual (the board as given
// does not fit the photos). With `motion`, the cameras' poses are in the
// world frame it defines (else the first camera's frame).
CameraCalibrationResult CalibrateCameras(const CalibrationBoard& board, const std::vector<CameraViews>& cameras,
                                         const CameraCalibrationOptions& options,
                                         const TurntableMotion* motion = nullptr);

// Each camera's distortion model, in order: what cross-validation's halves
// are calibrated with (CameraCalibrationOptions::distortion_models).
std::vector<DistortionModel> ChosenDistortionModels(const CameraCalibrationResult& result);

// The pixel where a camera-frame point projects through the OpenCV model.
Eigen::Vector2d ProjectInCamera(const formats::CameraCalibration& camera, const Eigen::Vector3d& point);
// The camera-frame point at depth z on pixel (u, v)'s ray.
Eigen::Vector3d UnprojectAtDepth(const formats::CameraCalibration& camera, const Eigen::Vector2d& pixel, double z);

}  // namespace mesocap::calibration
