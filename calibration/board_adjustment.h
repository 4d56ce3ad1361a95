// The least-squares problem of camera calibration from photos of a board
// (Zhang's pinhole and Brown-Conrady model, refined jointly over every
// camera and board pose): its unknowns, the corners it fits, the solve and
// the parameters' covariance. Solved in scaled units so that the
// covariance's conditioning measures what the photos leave unobserved.
// Used by calibration/camera_calibration.cc.
#pragma once

#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <Eigen/Core>
#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "calibration/camera_calibration.h"

namespace mesocap::calibration::board_adjustment {

constexpr int kIntrinsicCount = 9;  // fx fy cx cy k1 k2 p1 p2 k3
constexpr int kPinholeCount = 4;    // fx fy cx cy, then the distortion terms
using Intrinsics = std::array<double, kIntrinsicCount>;
constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

// OpenCV's pinhole and Brown-Conrady model (the same as cv::projectPoints).
template <typename T>
void ProjectOpenCv(const T* k, const T* p, T* uv) {
  const T x = p[0] / p[2], y = p[1] / p[2];
  const T r2 = x * x + y * y;
  const T radial = T(1) + r2 * (k[4] + r2 * (k[5] + r2 * k[8]));
  const T xd = x * radial + T(2) * k[6] * x * y + k[7] * (r2 + T(2) * x * x);
  const T yd = y * radial + k[6] * (r2 + T(2) * y * y) + T(2) * k[7] * x * y;
  uv[0] = k[0] * xd + k[2];
  uv[1] = k[1] * yd + k[3];
}

// A pose parent <- child as a unit quaternion (w x y z, Ceres' order, on
// Ceres' QuaternionManifold, whose tangent is half a rotation vector about
// the parent's axes: twice it is the format's uncertainty convention) and a
// translation.
struct Pose {
  std::array<double, 4> q{1, 0, 0, 0};
  std::array<double, 3> t{0, 0, 0};
};

Pose FromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec);
Eigen::Matrix3d Rotation(const Pose& p);
Pose FromMatrix(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);
Pose Compose(const Pose& a, const Pose& b);  // a * b
Pose Inverse(const Pose& a);

struct Observation {
  int camera = 0;
  int instant = 0;
  Eigen::Vector2d pixel;
  Eigen::Vector3d board_point;
  bool inlier = true;
};

// The problem's unknowns: per camera its intrinsics and reference <- camera
// (the first camera is the reference), per instant reference <- board.
struct Unknowns {
  std::vector<Intrinsics> intrinsics;
  // Per camera; empty: every term. The terms a model leaves out are held at zero.
  std::vector<DistortionModel> models;
  std::vector<Pose> cameras;
  std::vector<Pose> boards;  // per instant; on a turntable derived from the holders
  std::vector<bool> board_seen;
  // On a turntable: the reference is the world (the turntable frame at
  // angle 0) and the board's poses follow from its holders' (turntable <-
  // board as yaw, tilt_x, tilt_y and a translation) and the angles.
  const TurntableMotion* motion = nullptr;
  std::vector<std::array<double, 3>> holder_angles, holder_t;
};

// turntable <- board of a holder.
Pose HolderPose(const Unknowns& u, std::size_t holder);

struct SolveSummary {
  double cost = 0;  // half the sum of squared residuals
  int residuals = 0;
  int tangent_parameters = 0;
};

// Physical-unit covariances of one camera's parameters, jointly: the
// intrinsics (9), the rotation's tangent (3: a rotation vector about the
// reference's axes, rad) and the centre (3, mm); the pose part is zero for
// the reference camera when it is the gauge.
constexpr int kCameraParameters = kIntrinsicCount + 6;
struct CameraCovariance {
  Eigen::Matrix<double, kCameraParameters, kCameraParameters> joint =
      Eigen::Matrix<double, kCameraParameters, kCameraParameters>::Zero();
  auto intrinsics() const { return joint.topLeftCorner<kIntrinsicCount, kIntrinsicCount>(); }
  auto rotation() const { return joint.block<3, 3>(kIntrinsicCount, kIntrinsicCount); }
  auto centre() const { return joint.bottomRightCorner<3, 3>(); }
};

// The least-squares problem over the unknowns, solved in the solver's units
// (kLengthUnitMm, focal units) and written back in physical units.
class BoardProblem {
 public:
  // corner_radius: per camera, the image corner's distance from the
  // principal point in pixels.
  BoardProblem(Unknowns* unknowns, const std::vector<Observation>& observations, double huber_px,
               const std::vector<double>& corner_radius);

  SolveSummary Solve();

  // (J^T J)^-1 at the solution for every camera, in physical units (not yet
  // scaled by the residual variance); false when J^T J is singular to
  // working precision (some parameter is not observed at all).
  bool Covariances(std::vector<CameraCovariance>* out);

 private:
  ceres::Manifold* HeldTerms(DistortionModel model);  // nullptr: none held

  Unknowns* unknowns_;
  Unknowns scaled_;
  std::vector<Intrinsics> units_;  // the solver's unit of each intrinsic
  ceres::QuaternionManifold quaternion_;
  // The intrinsics with the distortion terms a model leaves out held constant.
  ceres::SubsetManifold no_distortion_{kIntrinsicCount, {4, 5, 6, 7, 8}};
  ceres::SubsetManifold k1_only_{kIntrinsicCount, {5, 6, 7, 8}};
  ceres::SubsetManifold k1_k2_only_{kIntrinsicCount, {6, 7, 8}};
  ceres::SubsetManifold fixed_first_{3, {0}};
  ceres::SubsetManifold fixed_third_{3, {2}};
  std::unique_ptr<ceres::Problem> problem_;
  SolveSummary summary_;
};

// A corner's reprojection residual (pixels) and its point in the camera's
// frame (mm), at the unknowns' current values.
Eigen::Vector2d Residual(const Unknowns& u, const Observation& o);
Eigen::Vector3d InCamera(const Unknowns& u, const Observation& o);

// On a turntable: the axis and the holders' poses from the free solution's
// board poses; the unknowns move into the world frame `motion` defines.
void InitTurntable(Unknowns* u, const TurntableMotion& motion);

}  // namespace mesocap::calibration::board_adjustment
