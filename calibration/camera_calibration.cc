#include "calibration/camera_calibration.h"

#include <ceres/rotation.h>
#include <tbb/parallel_for.h>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <opencv2/calib3d.hpp>
#include <queue>

#include "calibration/board_adjustment.h"

namespace mesocap::calibration {
namespace {

using board_adjustment::BoardProblem;
using board_adjustment::CameraCovariance;
using board_adjustment::Compose;
using board_adjustment::FromRvecTvec;
using board_adjustment::HolderPose;
using board_adjustment::InCamera;
using board_adjustment::InitTurntable;
using board_adjustment::Inverse;
using board_adjustment::kCameraParameters;
using board_adjustment::kIntrinsicCount;
using board_adjustment::kPinholeCount;
using board_adjustment::kRadToDeg;
using board_adjustment::Observation;
using board_adjustment::Pose;
using board_adjustment::ProjectOpenCv;
using board_adjustment::Residual;
using board_adjustment::Rotation;
using board_adjustment::SolveSummary;
using board_adjustment::Unknowns;

constexpr const char* kIntrinsicNames[kIntrinsicCount] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};

double Median(std::vector<double> values) {
  if (values.empty()) return std::nan("");
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

formats::CameraCalibration ToCalibration(const CameraViews& views, const std::array<double, kIntrinsicCount>& k,
                                         const Pose& pose) {
  formats::CameraCalibration camera;
  camera.id = views.id;
  camera.width = views.width;
  camera.height = views.height;
  camera.intrinsics.fx = k[0];
  camera.intrinsics.fy = k[1];
  camera.intrinsics.cx = k[2];
  camera.intrinsics.cy = k[3];
  camera.distortion.k1 = k[4];
  camera.distortion.k2 = k[5];
  camera.distortion.p1 = k[6];
  camera.distortion.p2 = k[7];
  camera.distortion.k3 = k[8];
  camera.pose.transform.parent_frame = "world";
  camera.pose.transform.child_frame = "camera:" + views.id;
  camera.pose.transform.rotation = Rotation(pose);
  camera.pose.transform.translation = Eigen::Vector3d(pose.t[0], pose.t[1], pose.t[2]);
  return camera;
}

std::array<double, kIntrinsicCount> IntrinsicArray(const formats::CameraCalibration& c) {
  return {c.intrinsics.fx, c.intrinsics.fy, c.intrinsics.cx, c.intrinsics.cy, c.distortion.k1,
          c.distortion.k2, c.distortion.p1, c.distortion.p2, c.distortion.k3};
}

// One sigma, pixels, of where camera c images the point the report is
// about (largest axis of the 2D ellipse; numerical Jacobian over the
// camera's 15 parameters, propagated through their joint covariance).
// On a turntable: the sample centre, the world's origin, through the
// intrinsics and the camera's pose (mrcal's reading: a point fixed in the
// world, whose image moves with both). Without: a point fixed in the camera
// on the ray through the image centre at the working distance, through the
// intrinsics alone: the first camera's pose is the gauge there, and this
// leaves out how the board poses would take up a principal point's error,
// so it errs on the large side.
double ProjectionSigma(const Unknowns& u, std::size_t c,
                       const Eigen::Matrix<double, kCameraParameters, kCameraParameters>& covariance, bool in_world,
                       double working_distance_mm) {
  const Eigen::Matrix3d rotation = Rotation(u.cameras[c]);
  const Eigen::Vector3d centre(u.cameras[c].t[0], u.cameras[c].t[1], u.cameras[c].t[2]);
  // Off the world: the point on the optical axis (the principal point's ray,
  // near the image centre's) at the working distance.
  const Eigen::Vector3d world = in_world ? Eigen::Vector3d(Eigen::Vector3d::Zero())
                                         : Eigen::Vector3d(centre + rotation.col(2) * working_distance_mm);
  Eigen::Matrix<double, kCameraParameters, kCameraParameters> used = covariance;
  if (!in_world) {
    used.bottomRows<6>().setZero();
    used.rightCols<6>().setZero();
  }
  const auto project = [&](const Eigen::Matrix<double, kCameraParameters, 1>& delta) {
    std::array<double, kIntrinsicCount> k = u.intrinsics[c];
    for (std::size_t i = 0; i < kIntrinsicCount; ++i) k[i] += delta[static_cast<int>(i)];
    const Eigen::Vector3d turn = delta.segment<3>(kIntrinsicCount);
    const Eigen::Matrix3d r = (turn.norm() > 0 ? Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix()
                                               : Eigen::Matrix3d::Identity()) *
                              rotation;
    const Eigen::Vector3d p = r.transpose() * (world - centre - delta.tail<3>());
    double uv[2];
    ProjectOpenCv(k.data(), p.data(), uv);
    return Eigen::Vector2d(uv[0], uv[1]);
  };
  Eigen::Matrix<double, 2, kCameraParameters> jacobian;
  for (int p = 0; p < kCameraParameters; ++p) {
    const double scale = p < kIntrinsicCount ? std::max(1.0, std::abs(u.intrinsics[c][static_cast<std::size_t>(p)]))
                         : p < kIntrinsicCount + 3 ? 1.0
                                                   : 100.0;
    Eigen::Matrix<double, kCameraParameters, 1> delta = Eigen::Matrix<double, kCameraParameters, 1>::Zero();
    delta[p] = 1e-7 * scale;
    jacobian.col(p) = (project(delta) - project(-delta)) / (2e-7 * scale);
  }
  const Eigen::Matrix2d projected = jacobian * used * jacobian.transpose();
  return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(projected).eigenvalues().maxCoeff()));
}

}  // namespace

const char* ToString(DistortionModel model) {
  switch (model) {
    case DistortionModel::kNone:
      return "none";
    case DistortionModel::kK1:
      return "k1";
    case DistortionModel::kK1K2:
      return "k1 k2";
    case DistortionModel::kFull:
      return "k1 k2 p1 p2 k3";
  }
  return "?";
}

int TermCount(DistortionModel model) {
  switch (model) {
    case DistortionModel::kNone:
      return 0;
    case DistortionModel::kK1:
      return 1;
    case DistortionModel::kK1K2:
      return 2;
    case DistortionModel::kFull:
      return 5;
  }
  return 5;
}

std::vector<DistortionModel> ChosenDistortionModels(const CameraCalibrationResult& result) {
  std::vector<DistortionModel> models;
  for (const CalibratedCamera& camera : result.cameras) models.push_back(camera.distortion_model);
  return models;
}

Eigen::Vector2d ProjectInCamera(const formats::CameraCalibration& camera, const Eigen::Vector3d& point) {
  const std::array<double, kIntrinsicCount> k = IntrinsicArray(camera);
  double uv[2];
  ProjectOpenCv(k.data(), point.data(), uv);
  return {uv[0], uv[1]};
}

Eigen::Vector3d UnprojectAtDepth(const formats::CameraCalibration& camera, const Eigen::Vector2d& pixel, double z) {
  const cv::Matx33d matrix(camera.intrinsics.fx, 0, camera.intrinsics.cx, 0, camera.intrinsics.fy, camera.intrinsics.cy,
                           0, 0, 1);
  const cv::Vec<double, 5> distortion(camera.distortion.k1, camera.distortion.k2, camera.distortion.p1,
                                      camera.distortion.p2, camera.distortion.k3);
  std::vector<cv::Point2d> in{{pixel.x(), pixel.y()}}, out;
  cv::undistortPoints(in, out, matrix, distortion, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
  return Eigen::Vector3d(out[0].x * z, out[0].y * z, z);
}

core::CheckResult CameraCalibrationOptions::Check() const {
  if (min_corners_per_view < 4 || min_corners_per_view > 100000) return "min corners per view must be 4..100000";
  if (min_views_per_camera < 1 || min_views_per_camera > 100000) return "min views per camera must be 1..100000";
  if (!(huber_px > 0 && huber_px <= 100)) return "Huber scale must be in (0, 100] px";
  if (!(outlier_corner_sigmas >= 2 && outlier_corner_sigmas <= 100)) return "outlier corner sigmas must be 2..100";
  if (!(outlier_image_ratio >= 1.5 && outlier_image_ratio <= 100)) return "outlier image ratio must be 1.5..100";
  if (!(max_edge_width_px > 0)) return "max edge width must be positive";
  if (!(max_saturated_fraction >= 0 && max_saturated_fraction <= 1)) return "max saturated fraction must be in [0, 1]";
  if (!(max_rms_px > 0)) return "max RMS must be positive";
  if (!(max_outlier_fraction > 0 && max_outlier_fraction < 1)) return "max outlier fraction must be in (0, 1)";
  if (!(warn_relative_focal_sigma > 0)) return "focal sigma warning level must be positive";
  return {};
}

void DetectBoardInPhotos(const BoardCornerDetector& detector,
                         const std::function<std::optional<core::Image>(std::size_t)>& read, CameraViews* views) {
  const std::size_t count = views->names.size();
  views->detections.assign(count, {});
  views->qualities.assign(count, {});
  std::vector<std::string> errors(count);
  tbb::parallel_for(std::size_t{0}, count, [&](std::size_t i) {
    try {
      const std::optional<core::Image> photo = read(i);
      if (!photo) return;
      views->detections[i] = detector.Detect(*photo);
      views->qualities[i] = detector.Quality(*photo, views->detections[i]);
    } catch (const core::Error& e) {
      errors[i] = e.what();
    }
  });
  for (const std::string& e : errors) {
    if (!e.empty()) throw core::Error(e);
  }
}

core::CheckResult TurntableMotion::Check(std::size_t instants) const {
  if (holder.size() != instants || angle_rad.size() != instants) {
    return "the turntable motion has " + std::to_string(holder.size()) + " holders and " +
           std::to_string(angle_rad.size()) + " angles for " + std::to_string(instants) + " instants";
  }
  for (std::size_t i = 0; i < instants; ++i) {
    if (holder[i] < 0 || holder[i] > 1000) return "holder index out of 0..1000";
    if (!std::isfinite(angle_rad[i])) return "turntable angle not finite";
  }
  if (!std::isfinite(board_height_mm)) return "board height not finite";
  return {};
}

namespace {

using Usable = std::vector<std::vector<bool>>;                     // per camera, per instant
using CameraFromBoard = std::vector<std::map<std::size_t, Pose>>;  // per camera: instant -> camera <- board

void CheckCalibrationInputs(const std::vector<CameraViews>& cameras, const CameraCalibrationOptions& options) {
  core::ThrowIfInvalid(options.Check(), "camera calibration");
  if (cameras.empty()) throw core::Error("camera calibration: no camera");
  if (options.distortion_models.size() > 1 && options.distortion_models.size() != cameras.size()) {
    throw core::Error("camera calibration: " + std::to_string(options.distortion_models.size()) +
                      " distortion models for " + std::to_string(cameras.size()) + " cameras");
  }
  const std::size_t instants = cameras[0].detections.size();
  for (const CameraViews& c : cameras) {
    if (c.detections.size() != instants || c.names.size() != instants ||
        (!c.qualities.empty() && c.qualities.size() != instants)) {
      throw core::Error("camera calibration: camera " + core::Quoted(c.id) + " has " +
                        std::to_string(c.detections.size()) + " photos, expected " + std::to_string(instants));
    }
  }
}

// Why one photo cannot be used (empty: it can); `outlier` tells a photo
// set aside for its quality from one where the board was not found.
std::string UnusablePhotoReason(const CameraViews& views, std::size_t i, const CameraCalibrationOptions& options,
                                bool* outlier) {
  const BoardDetection& d = views.detections[i];
  *outlier = false;
  if (d.empty()) return "board not found";
  if (static_cast<int>(d.size()) < options.min_corners_per_view) {
    return "only " + std::to_string(d.size()) + " corners found (" + std::to_string(options.min_corners_per_view) +
           " needed)";
  }
  if (views.qualities.empty()) return "";
  const DetectionQuality& q = views.qualities[i];
  *outlier = true;
  if (q.saturated_fraction > options.max_saturated_fraction) {
    return "saturated: " + core::Fixed(100 * q.saturated_fraction, 1) + " % of the board's pixels at full scale";
  }
  if (q.edge_width_px > options.max_edge_width_px) {
    return "blurred: the board's edges are " + core::Fixed(q.edge_width_px, 1) + " px wide (at most " +
           core::Fixed(options.max_edge_width_px, 1) + ")";
  }
  return "";
}

// Which photos are usable, and why the others are not.
Usable SelectUsablePhotos(const CalibrationBoard& board, const std::vector<CameraViews>& cameras,
                          const CameraCalibrationOptions& options, CameraCalibrationResult* result) {
  const std::size_t instants = cameras[0].detections.size();
  Usable usable(cameras.size(), std::vector<bool>(instants, false));
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const CameraViews& views = cameras[c];
    CalibratedCamera& out = result->cameras[c];
    for (std::size_t i = 0; i < instants; ++i) {
      bool outlier = false;
      const std::string reason = UnusablePhotoReason(views, i, options, &outlier);
      if (reason.empty()) {
        usable[c][i] = true;
      } else {
        (outlier ? out.outlier_images : out.unused_images).push_back({views.names[i], reason});
      }
    }
    const int count = static_cast<int>(std::count(usable[c].begin(), usable[c].end(), true));
    if (count == 0) {
      throw core::Error("camera " + core::Quoted(views.id) + " never sees the board " + core::Quoted(board.Spec()) +
                        " in its " + std::to_string(instants) + " photos (no usable view)");
    }
    if (count < options.min_views_per_camera) {
      throw core::Error("camera " + core::Quoted(views.id) + " sees the board in only " + std::to_string(count) +
                        " usable photos; at least " + std::to_string(options.min_views_per_camera) + " are needed");
    }
  }
  return usable;
}

// Zhang's method per camera (OpenCV's): its intrinsics and each usable
// view's camera <- board.
CameraFromBoard InitializeWithZhang(const CalibrationBoard& board, const std::vector<CameraViews>& cameras,
                                    const Usable& usable, Unknowns* unknowns) {
  const std::size_t instants = cameras[0].detections.size();
  unknowns->intrinsics.resize(cameras.size());
  unknowns->cameras.resize(cameras.size());
  unknowns->boards.resize(instants);
  unknowns->board_seen.assign(instants, false);
  CameraFromBoard camera_from_board(cameras.size());
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    std::vector<std::vector<cv::Point3f>> object_points;
    std::vector<std::vector<cv::Point2f>> image_points;
    std::vector<std::size_t> views;
    for (std::size_t i = 0; i < instants; ++i) {
      if (!usable[c][i]) continue;
      const BoardDetection& d = cameras[c].detections[i];
      object_points.emplace_back();
      image_points.emplace_back();
      for (std::size_t j = 0; j < d.size(); ++j) {
        const Eigen::Vector3d p = board.CornerPosition(d.ids[j]);
        object_points.back().emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), 0.0f);
        image_points.back().emplace_back(static_cast<float>(d.pixels[j].x()), static_cast<float>(d.pixels[j].y()));
      }
      views.push_back(i);
    }
    cv::Mat matrix, distortion;
    std::vector<cv::Mat> rvecs, tvecs;
    try {
      cv::calibrateCamera(object_points, image_points, cv::Size(cameras[c].width, cameras[c].height), matrix,
                          distortion, rvecs, tvecs, cv::CALIB_FIX_K3);
    } catch (const cv::Exception& e) {
      throw core::Error("camera " + core::Quoted(cameras[c].id) +
                        ": Zhang's initial calibration failed: " + core::Cut(e.what()));
    }
    unknowns->intrinsics[c] = {matrix.at<double>(0, 0),  matrix.at<double>(1, 1),  matrix.at<double>(0, 2),
                               matrix.at<double>(1, 2),  distortion.at<double>(0), distortion.at<double>(1),
                               distortion.at<double>(2), distortion.at<double>(3), 0.0};
    for (std::size_t v = 0; v < views.size(); ++v) {
      camera_from_board[c][views[v]] = FromRvecTvec(rvecs[v], tvecs[v]);
    }
  }
  return camera_from_board;
}

// Cameras' poses in the first camera's frame, through shared instants
// (breadth first, each link through the instant where both see the most),
// then each instant's board in that frame.
void ChainCameraPoses(const std::vector<CameraViews>& cameras, CameraFromBoard& camera_from_board, Unknowns* unknowns) {
  const std::size_t instants = cameras[0].detections.size();
  std::vector<bool> placed(cameras.size(), false);
  placed[0] = true;
  std::queue<std::size_t> frontier;
  frontier.push(0);
  while (!frontier.empty()) {
    const std::size_t known = frontier.front();
    frontier.pop();
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      if (placed[c]) continue;
      std::size_t best = instants, best_corners = 0;
      for (const auto& [i, pose] : camera_from_board[c]) {
        if (!camera_from_board[known].count(i)) continue;
        const std::size_t corners = std::min(cameras[c].detections[i].size(), cameras[known].detections[i].size());
        if (corners > best_corners) best = i, best_corners = corners;
      }
      if (best == instants) continue;
      // reference <- c = (reference <- known)(known <- board)(board <- c)
      unknowns->cameras[c] = Compose(Compose(unknowns->cameras[known], camera_from_board[known][best]),
                                     Inverse(camera_from_board[c][best]));
      placed[c] = true;
      frontier.push(c);
    }
  }
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    if (!placed[c]) {
      throw core::Error("camera " + core::Quoted(cameras[c].id) + " shares no photo of the board with camera " +
                        core::Quoted(cameras[0].id) + " or any camera linked to it: its pose cannot be found");
    }
  }
  for (std::size_t i = 0; i < instants; ++i) {
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      const auto found = camera_from_board[c].find(i);
      if (found == camera_from_board[c].end()) continue;
      unknowns->boards[i] = Compose(unknowns->cameras[c], found->second);
      unknowns->board_seen[i] = true;
      break;
    }
  }
}

std::vector<Observation> CollectCorners(const CalibrationBoard& board, const std::vector<CameraViews>& cameras,
                                        const Usable& usable) {
  std::vector<Observation> observations;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    for (std::size_t i = 0; i < usable[c].size(); ++i) {
      if (!usable[c][i]) continue;
      const BoardDetection& d = cameras[c].detections[i];
      for (std::size_t j = 0; j < d.size(); ++j) {
        observations.push_back({static_cast<int>(c), static_cast<int>(i), d.pixels[j], board.CornerPosition(d.ids[j])});
      }
    }
  }
  return observations;
}

// Corners far beyond the rest after the robust solve; their squared
// residuals, per observation, for the photos' test.
std::vector<double> SetAsideOutlierCorners(const CalibrationBoard& board, const CameraCalibrationOptions& options,
                                           const Unknowns& unknowns, std::vector<Observation>* observations,
                                           CameraCalibrationResult* result) {
  std::vector<double> squared;
  for (const Observation& o : *observations) squared.push_back(Residual(unknowns, o).squaredNorm());
  // A 2D residual with per-coordinate sigma s has median squared norm
  // 2 ln 2 s^2.
  const double robust_sigma = std::sqrt(Median(squared) / (2 * std::log(2.0)));
  const double corner_limit = std::max(options.outlier_corner_sigmas * robust_sigma, 0.25);
  int outliers = 0;
  for (std::size_t n = 0; n < observations->size(); ++n) {
    if (std::sqrt(squared[n]) > corner_limit) {
      (*observations)[n].inlier = false;
      ++outliers;
      ++result->cameras[static_cast<std::size_t>((*observations)[n].camera)].outlier_corners;
    }
  }
  if (outliers > options.max_outlier_fraction * static_cast<double>(observations->size())) {
    double sum = 0;
    for (const double s : squared) sum += s;
    throw core::Error("the board " + core::Quoted(board.Spec()) + " does not fit the photos: reprojection RMS " +
                      core::Fixed(std::sqrt(sum / static_cast<double>(observations->size())), 2) + " px over " +
                      std::to_string(observations->size()) + " corners, " + std::to_string(outliers) +
                      " of them beyond " + core::Fixed(corner_limit, 2) +
                      " px; check the board's size, squares and dictionary");
  }
  return squared;
}

// Photos that fit much worse than the median photo (on their inlier
// corners); throws when a camera keeps too few.
void SetAsideOutlierPhotos(const std::vector<CameraViews>& cameras, const CameraCalibrationOptions& options,
                           const std::vector<double>& squared, std::vector<Observation>* observations, Usable* usable,
                           CameraCalibrationResult* result) {
  std::map<std::pair<int, int>, std::pair<double, int>> per_photo;  // (camera, instant) -> (sum, count)
  for (std::size_t n = 0; n < observations->size(); ++n) {
    if (!(*observations)[n].inlier) continue;
    auto& entry = per_photo[{(*observations)[n].camera, (*observations)[n].instant}];
    entry.first += squared[n];
    entry.second += 1;
  }
  std::vector<double> photo_rms;
  for (const auto& [key, entry] : per_photo) photo_rms.push_back(std::sqrt(entry.first / entry.second));
  const double median_photo_rms = Median(photo_rms);
  for (const auto& [key, entry] : per_photo) {
    const double rms = std::sqrt(entry.first / entry.second);
    if (rms <= options.outlier_image_ratio * median_photo_rms || rms <= 0.5) continue;
    const auto [c, i] = key;
    (*usable)[static_cast<std::size_t>(c)][static_cast<std::size_t>(i)] = false;
    result->cameras[static_cast<std::size_t>(c)].outlier_images.push_back(
        {cameras[static_cast<std::size_t>(c)].names[static_cast<std::size_t>(i)],
         "reprojection RMS " + core::Fixed(rms, 2) + " px, " + core::Fixed(rms / median_photo_rms, 1) +
             " times the median photo's"});
    for (Observation& o : *observations) {
      if (o.camera == c && o.instant == i) o.inlier = false;
    }
  }
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const int count = static_cast<int>(std::count((*usable)[c].begin(), (*usable)[c].end(), true));
    if (count < options.min_views_per_camera) {
      throw core::Error("camera " + core::Quoted(cameras[c].id) + " keeps only " + std::to_string(count) +
                        " photos after outliers are set aside; at least " +
                        std::to_string(options.min_views_per_camera) + " are needed");
    }
  }
}

// The least-squares solution on the inliers: the residual variance and,
// when J^T J can be inverted, each camera's covariance.
struct InlierSolution {
  double variance = 0;
  std::vector<CameraCovariance> covariances;  // empty: not computed
};

InlierSolution SolveOnInliers(Unknowns* unknowns, const std::vector<Observation>& observations,
                              const std::vector<double>& corner_radius, CameraCalibrationResult* result) {
  BoardProblem final_problem(unknowns, observations, 0.0, corner_radius);
  const SolveSummary solved = final_problem.Solve();
  const int dof = solved.residuals - solved.tangent_parameters;
  if (dof <= 0) {
    throw core::Error("camera calibration: " + std::to_string(solved.residuals / 2) + " corners cannot determine " +
                      std::to_string(solved.tangent_parameters) + " parameters; take more photos");
  }
  InlierSolution solution;
  solution.variance = 2 * solved.cost / dof;
  result->residual_sigma_px = std::sqrt(solution.variance);
  if (!final_problem.Covariances(&solution.covariances)) {
    solution.covariances.clear();
    result->warnings.push_back(
        "the parameters' covariance could not be computed (J^T J is singular to working precision: some "
        "parameters, such as the focal length with every photo square to the camera, are not observed); no "
        "uncertainty is reported and the values are not to be trusted");
  }
  return solution;
}

// One rung of the ladder solved for every camera at once on the inlier
// corners: the solution, each camera's RSS and, when asked, its intrinsics'
// sigmas (infinite where the covariance cannot be computed or was not asked
// for: the simplest rung's are never needed).
struct SolvedRung {
  Unknowns solution;
  std::vector<double> rss;
  std::vector<Eigen::Matrix<double, kIntrinsicCount, 1>> sigma;
  double variance = 0;
};

SolvedRung SolveRung(Unknowns start, DistortionModel model, const std::vector<Observation>& observations,
                     const std::vector<double>& corner_radius, bool with_sigmas) {
  const std::size_t count = start.intrinsics.size();
  start.models.assign(count, model);
  BoardProblem problem(&start, observations, 0.0, corner_radius);
  const SolveSummary solved = problem.Solve();
  SolvedRung rung;
  rung.variance = std::max(2 * solved.cost / std::max(1, solved.residuals - solved.tangent_parameters), 1e-12);
  rung.rss.assign(count, 0.0);
  for (const Observation& o : observations) {
    if (o.inlier) rung.rss[static_cast<std::size_t>(o.camera)] += Residual(start, o).squaredNorm();
  }
  std::vector<CameraCovariance> covariances;
  const bool known = with_sigmas && problem.Covariances(&covariances);
  for (std::size_t c = 0; c < count; ++c) {
    rung.sigma.push_back(known ? Eigen::Matrix<double, kIntrinsicCount, 1>(
                                     (rung.variance * covariances[c].intrinsics().diagonal()).cwiseSqrt())
                               : Eigen::Matrix<double, kIntrinsicCount, 1>::Constant(HUGE_VAL));
  }
  rung.solution = std::move(start);
  return rung;
}

// The rule of camera_calibration.h: may camera c leave out what rung r + 1
// adds to rung r?
bool MayStepDown(const std::vector<SolvedRung>& rungs, const std::vector<DistortionRung>& ladder, std::size_t c,
                 std::size_t r) {
  const auto& richer = rungs[r + 1].solution.intrinsics[c];
  const auto& simpler = rungs[r].solution.intrinsics[c];
  const auto& sigma = rungs[r + 1].sigma[c];
  bool undetermined = true;
  for (int i = kPinholeCount + TermCount(kDistortionLadder[r]); i < kPinholeCount + TermCount(kDistortionLadder[r + 1]);
       ++i) {
    undetermined = undetermined && sigma[i] > std::abs(richer[static_cast<std::size_t>(i)]);
  }
  if (!(ladder[r].aic <= ladder[r + 1].aic || undetermined)) return false;
  for (int i = 0; i < kPinholeCount; ++i) {
    if (std::abs(simpler[static_cast<std::size_t>(i)] - richer[static_cast<std::size_t>(i)]) > sigma[i]) return false;
  }
  return true;
}

// Each camera's distortion model: given, or chosen by the ladder (the rule
// in camera_calibration.h). Every rung is solved for all cameras at once,
// richest first, each warm-started from the one above; the unknowns come
// back at the chosen rung's solution.
void ChooseDistortionModels(const std::vector<CameraViews>& cameras, const CameraCalibrationOptions& options,
                            const std::vector<Observation>& observations, const std::vector<double>& corner_radius,
                            Unknowns* unknowns, CameraCalibrationResult* result) {
  const std::size_t count = cameras.size();
  if (!options.distortion_models.empty()) {
    unknowns->models = options.distortion_models;
    unknowns->models.resize(count, options.distortion_models.front());
    for (std::size_t c = 0; c < count; ++c) result->cameras[c].distortion_model = unknowns->models[c];
    return;
  }
  constexpr std::size_t kRungs = std::size(kDistortionLadder);
  std::vector<SolvedRung> rungs(kRungs);
  for (std::size_t r = kRungs; r-- > 0;) {
    rungs[r] = SolveRung(r + 1 == kRungs ? *unknowns : rungs[r + 1].solution, kDistortionLadder[r], observations,
                         corner_radius, r > 0);
  }
  std::vector<double> corners(count, 0.0);
  for (const Observation& o : observations) corners[static_cast<std::size_t>(o.camera)] += o.inlier ? 1 : 0;
  std::vector<std::size_t> chosen(count, kRungs - 1);
  for (std::size_t c = 0; c < count; ++c) {
    CalibratedCamera& out = result->cameras[c];
    for (std::size_t r = 0; r < kRungs; ++r) {
      const double rss = rungs[r].rss[c];
      const double aic = rss / rungs[kRungs - 1].variance + 2.0 * TermCount(kDistortionLadder[r]);
      out.distortion_ladder.push_back({kDistortionLadder[r], std::sqrt(rss / std::max(1.0, corners[c])), aic});
    }
    while (chosen[c] > 0 && MayStepDown(rungs, out.distortion_ladder, c, chosen[c] - 1)) --chosen[c];
    out.distortion_model = kDistortionLadder[chosen[c]];
  }
  // One rung for every camera: its solution. Mixed: the richest's, which
  // the final solve takes on from there.
  const bool same = std::all_of(chosen.begin(), chosen.end(), [&](std::size_t r) { return r == chosen[0]; });
  *unknowns = rungs[same ? chosen[0] : kRungs - 1].solution;
  unknowns->models = ChosenDistortionModels(*result);
}

// Camera c's calibration, fit and uncertainties as the report gives them.
void DescribeCamera(std::size_t c, const std::vector<CameraViews>& cameras, const CameraCalibrationOptions& options,
                    const Unknowns& unknowns, const std::vector<Observation>& observations, const Usable& usable,
                    const InlierSolution& solution, bool on_turntable, CameraCalibrationResult* result) {
  CalibratedCamera& out = result->cameras[c];
  out.calibration = ToCalibration(cameras[c], unknowns.intrinsics[c], unknowns.cameras[c]);
  double sum = 0;
  std::vector<double> depths;
  for (const Observation& o : observations) {
    if (!o.inlier || o.camera != static_cast<int>(c)) continue;
    sum += Residual(unknowns, o).squaredNorm();
    depths.push_back(InCamera(unknowns, o).z());
    ++out.corners_used;
  }
  out.images_used = static_cast<int>(std::count(usable[c].begin(), usable[c].end(), true));
  out.rms_px = std::sqrt(sum / std::max(1, out.corners_used));
  out.working_distance_mm = Median(depths);
  if (solution.covariances.empty()) return;
  const double variance = solution.variance;
  const CameraCovariance& covariance = solution.covariances[c];
  const Eigen::Matrix<double, kIntrinsicCount, kIntrinsicCount> k_cov = variance * covariance.intrinsics();
  const Eigen::Matrix<double, kIntrinsicCount, 1> k_std = k_cov.diagonal().cwiseSqrt();
  formats::CameraCalibration& cal = out.calibration;
  cal.intrinsics.uncertainty = {k_std[0], k_std[1], k_std[2], k_std[3]};
  cal.distortion.uncertainty = {k_std[4], k_std[5], k_std[6], k_std[7], k_std[8]};
  for (int term = 0; term < TermCount(out.distortion_model); ++term) {
    const auto i = static_cast<std::size_t>(4 + term);
    if (k_std[static_cast<int>(i)] > std::abs(unknowns.intrinsics[c][i])) {
      out.undetermined_terms.push_back(kIntrinsicNames[i]);
    }
  }
  out.projection_uncertainty_px =
      ProjectionSigma(unknowns, c, variance * covariance.joint, on_turntable, out.working_distance_mm);
  for (const int f : {0, 1}) {
    const double relative = k_std[f] / unknowns.intrinsics[c][static_cast<std::size_t>(f)];
    if (relative > options.warn_relative_focal_sigma) {
      result->warnings.push_back(
          "camera " + core::Quoted(cameras[c].id) + ": focal length poorly observed (" + kIntrinsicNames[f] + " " +
          core::Fixed(unknowns.intrinsics[c][static_cast<std::size_t>(f)], 1) + " +- " + core::Fixed(k_std[f], 1) +
          " px, " + core::Fixed(100 * relative, 2) + " %): tilt the board more between photos");
      break;
    }
  }
  if (c == 0 && !on_turntable) return;
  cal.pose.uncertainty.rotation_rad = (variance * covariance.rotation().diagonal()).cwiseSqrt();
  cal.pose.uncertainty.translation_mm = (variance * covariance.centre().diagonal()).cwiseSqrt();
}

// Each camera's pose relative to the first, and on a turntable each
// holder's board pose.
void DescribeRelativePoses(const std::vector<CameraViews>& cameras, const Unknowns& unknowns, bool on_turntable,
                           CameraCalibrationResult* result) {
  for (std::size_t c = 1; c < cameras.size(); ++c) {
    const formats::CameraCalibration& cal = result->cameras[c].calibration;
    RelativePose relative;
    relative.from = cameras[0].id;
    relative.to = cameras[c].id;
    const Pose first_from_c = Compose(Inverse(unknowns.cameras[0]), unknowns.cameras[c]);
    double aa[3];
    ceres::QuaternionToAngleAxis(first_from_c.q.data(), aa);
    relative.rotation_deg = Eigen::Vector3d(aa[0], aa[1], aa[2]) * kRadToDeg;
    relative.translation_mm = Eigen::Vector3d(first_from_c.t[0], first_from_c.t[1], first_from_c.t[2]);
    if (!on_turntable && cal.pose.uncertainty.rotation_rad) {
      relative.rotation_std_deg = *cal.pose.uncertainty.rotation_rad * kRadToDeg;
      relative.translation_std_mm = *cal.pose.uncertainty.translation_mm;
      relative.has_std = true;
    }
    result->relative_poses.push_back(relative);
  }
  for (std::size_t h = 0; on_turntable && h < unknowns.holder_angles.size(); ++h) {
    const Pose pose = HolderPose(unknowns, h);
    core::RigidTransform holder;
    holder.parent_frame = "turntable";
    holder.child_frame = "board";
    holder.rotation = Rotation(pose);
    holder.translation = Eigen::Vector3d(pose.t[0], pose.t[1], pose.t[2]);
    result->holder_poses.push_back(holder);
  }
}

void CheckEveryCameraFits(const CalibrationBoard& board, const CameraCalibrationOptions& options,
                          const CameraCalibrationResult& result) {
  for (const CalibratedCamera& c : result.cameras) {
    if (c.rms_px > options.max_rms_px) {
      throw core::Error("the board " + core::Quoted(board.Spec()) + " does not fit the photos of camera " +
                        core::Quoted(c.calibration.id) + ": reprojection RMS " + core::Fixed(c.rms_px, 2) +
                        " px over " + std::to_string(c.corners_used) + " corners (at most " +
                        core::Fixed(options.max_rms_px, 2) +
                        " px expected); check the board's size, squares and dictionary");
    }
  }
}

}  // namespace

CameraCalibrationResult CalibrateCameras(const CalibrationBoard& board, const std::vector<CameraViews>& cameras,
                                         const CameraCalibrationOptions& options, const TurntableMotion* motion) {
  CheckCalibrationInputs(cameras, options);
  CameraCalibrationResult result;
  result.cameras.resize(cameras.size());
  Usable usable = SelectUsablePhotos(board, cameras, options, &result);
  Unknowns unknowns;
  CameraFromBoard camera_from_board = InitializeWithZhang(board, cameras, usable, &unknowns);
  ChainCameraPoses(cameras, camera_from_board, &unknowns);
  std::vector<double> corner_radius;
  for (const CameraViews& c : cameras) corner_radius.push_back(0.5 * std::hypot(c.width, c.height));
  std::vector<Observation> observations = CollectCorners(board, cameras, usable);
  if (motion) {
    if (const core::CheckResult problem = motion->Check(cameras[0].detections.size()); !problem.empty()) {
      throw core::Error("camera calibration: " + problem);
    }
    BoardProblem(&unknowns, observations, options.huber_px, corner_radius).Solve();
    InitTurntable(&unknowns, *motion);
  }
  // Robust solve, then outliers: corners far beyond the rest, then photos
  // that fit much worse than the median photo.
  BoardProblem(&unknowns, observations, options.huber_px, corner_radius).Solve();
  const std::vector<double> squared = SetAsideOutlierCorners(board, options, unknowns, &observations, &result);
  SetAsideOutlierPhotos(cameras, options, squared, &observations, &usable, &result);
  ChooseDistortionModels(cameras, options, observations, corner_radius, &unknowns, &result);
  const InlierSolution solution = SolveOnInliers(&unknowns, observations, corner_radius, &result);
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    DescribeCamera(c, cameras, options, unknowns, observations, usable, solution, motion != nullptr, &result);
  }
  DescribeRelativePoses(cameras, unknowns, motion != nullptr, &result);
  CheckEveryCameraFits(board, options, result);
  return result;
}

}  // namespace mesocap::calibration
