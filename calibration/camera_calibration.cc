#include "calibration/camera_calibration.h"

#include <algorithm>
#include <array>
#include <Eigen/Geometry>
#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/rotation.h>
#include <cmath>
#include <map>
#include <opencv2/calib3d.hpp>
#include <queue>
#include <tbb/parallel_for.h>
#include <sstream>

namespace mesocap::calibration {
namespace {

constexpr int kIntrinsicCount = 9;  // fx fy cx cy k1 k2 p1 p2 k3
constexpr const char* kIntrinsicNames[kIntrinsicCount] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
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

// The solver's units: lengths in kLengthUnitMm, the pinhole's four
// intrinsics in units of the camera's initial focal length, and each
// distortion coefficient in the unit that moves the image's corner by about
// a pixel, so that the Jacobian's columns are of one magnitude and the
// covariance's conditioning measures what the photos leave unobserved, not
// a choice of units (k3 of a narrow lens moves its corner by 1e-5 px per
// unit, a condition number no solver resolves).
constexpr double kLengthUnitMm = 100.0;

// A point in the reference frame (world on a turntable, else the first
// camera's) into a camera (reference <- camera = (camera_q, camera_c)),
// projected; the residual is in pixels.
using IntrinsicUnits = std::array<double, kIntrinsicCount>;

template <typename T>
void ReprojectionResidual(const T* scaled_k, const IntrinsicUnits& units, const T* camera_q, const T* camera_c,
                          const T* in_reference, const Eigen::Vector2d& observed, T* residual) {
  T k[kIntrinsicCount];
  for (int i = 0; i < kIntrinsicCount; ++i) k[i] = scaled_k[i] * units[static_cast<std::size_t>(i)];
  const T relative[3] = {in_reference[0] - camera_c[0], in_reference[1] - camera_c[1], in_reference[2] - camera_c[2]};
  const T inverse[4] = {camera_q[0], -camera_q[1], -camera_q[2], -camera_q[3]};
  T in_camera[3];
  ceres::QuaternionRotatePoint(inverse, relative, in_camera);
  T uv[2];
  ProjectOpenCv(k, in_camera, uv);
  residual[0] = uv[0] - T(observed.x());
  residual[1] = uv[1] - T(observed.y());
}

// One detected corner, the board free at its instant (reference <- board).
struct CornerResidual {
  Eigen::Vector2d observed;
  Eigen::Vector3d board_point;  // in kLengthUnitMm
  IntrinsicUnits units{1, 1, 1, 1, 1, 1, 1, 1, 1};

  template <typename T>
  bool operator()(const T* scaled_k, const T* camera_q, const T* camera_c, const T* board_q, const T* board_t,
                  T* residual) const {
    const T point[3] = {T(board_point.x()), T(board_point.y()), T(board_point.z())};
    T in_reference[3];
    ceres::QuaternionRotatePoint(board_q, point, in_reference);
    for (int i = 0; i < 3; ++i) in_reference[i] += board_t[i];
    ReprojectionResidual(scaled_k, units, camera_q, camera_c, in_reference, observed, residual);
    return true;
  }
};

// A weak prior on the distortion coefficients, in the solver's units (a
// unit moves the image's corner by a pixel): zero, with a sigma of
// kDistortionPriorPx. It leaves what the corners observe as it is, and keeps
// what they do not (k3 of a narrow lens seen over part of its field) from
// making J^T J singular: such a coefficient then reports a sigma near the
// prior's, honestly unknown, instead of no uncertainty at all.
constexpr double kDistortionPriorPx = 100.0;

struct DistortionPrior {
  template <typename T>
  bool operator()(const T* scaled_k, T* residual) const {
    for (int i = 0; i < 5; ++i) residual[i] = scaled_k[4 + i] / T(kDistortionPriorPx);
    return true;
  }
};

// turntable <- board on a holder: Rz(yaw) Ry(pitch) Rx(roll), then the
// translation. Yaw is the azimuth of the board's x axis (which the first
// holder's fixes to 0, the world's gauge); the angles are singular only
// with the board's x axis vertical (pitch 90 degrees), which no holder does.
template <typename T>
void HolderToTurntable(const T* angles, const T* t, const T* point, T* out) {
  const T cz = cos(angles[0]), sz = sin(angles[0]);
  const T cx = cos(angles[1]), sx = sin(angles[1]);
  const T cy = cos(angles[2]), sy = sin(angles[2]);
  const T a[3] = {point[0], cx * point[1] - sx * point[2], sx * point[1] + cx * point[2]};
  const T b[3] = {cy * a[0] + sy * a[2], a[1], -sy * a[0] + cy * a[2]};
  out[0] = cz * b[0] - sz * b[1] + t[0];
  out[1] = sz * b[0] + cz * b[1] + t[1];
  out[2] = b[2] + t[2];
}

// One detected corner with the board on a holder on the turntable, turned
// to `angle_rad` about the world's z axis (the turntable's axis).
struct TurntableCornerResidual {
  Eigen::Vector2d observed;
  Eigen::Vector3d board_point;  // in kLengthUnitMm
  IntrinsicUnits units{1, 1, 1, 1, 1, 1, 1, 1, 1};
  double angle_rad = 0;

  template <typename T>
  bool operator()(const T* scaled_k, const T* camera_q, const T* camera_c, const T* holder_angles,
                  const T* holder_t, T* residual) const {
    const T point[3] = {T(board_point.x()), T(board_point.y()), T(board_point.z())};
    T on_table[3];
    HolderToTurntable(holder_angles, holder_t, point, on_table);
    const T c(std::cos(angle_rad)), s(std::sin(angle_rad));
    const T in_world[3] = {c * on_table[0] - s * on_table[1], s * on_table[0] + c * on_table[1], on_table[2]};
    ReprojectionResidual(scaled_k, units, camera_q, camera_c, in_world, observed, residual);
    return true;
  }
};

struct Observation {
  int camera = 0;
  int instant = 0;
  Eigen::Vector2d pixel;
  Eigen::Vector3d board_point;
  bool inlier = true;
};

Pose FromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  double aa[3] = {rvec[0], rvec[1], rvec[2]};
  Pose pose;
  ceres::AngleAxisToQuaternion(aa, pose.q.data());
  pose.t = {tvec[0], tvec[1], tvec[2]};
  return pose;
}

Eigen::Matrix3d Rotation(const Pose& p) {
  double r[9];
  ceres::QuaternionToRotation(p.q.data(), r);
  Eigen::Matrix3d m;
  m << r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8];
  return m;
}

Pose FromMatrix(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation) {
  const Eigen::Matrix<double, 3, 3, Eigen::RowMajor> r = rotation;
  Pose pose;
  ceres::RotationMatrixToQuaternion(ceres::RowMajorAdapter3x3(r.data()), pose.q.data());
  pose.t = {translation.x(), translation.y(), translation.z()};
  return pose;
}

Pose Compose(const Pose& a, const Pose& b) {  // a * b
  const Eigen::Vector3d t = Rotation(a) * Eigen::Vector3d(b.t[0], b.t[1], b.t[2]) + Eigen::Vector3d(a.t[0], a.t[1], a.t[2]);
  return FromMatrix(Rotation(a) * Rotation(b), t);
}

Pose Inverse(const Pose& a) {
  const Eigen::Matrix3d r = Rotation(a).transpose();
  return FromMatrix(r, -r * Eigen::Vector3d(a.t[0], a.t[1], a.t[2]));
}

double Median(std::vector<double> values) {
  if (values.empty()) return std::nan("");
  const auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// The problem's unknowns: per camera its intrinsics and reference <- camera
// (the first camera is the reference), per instant reference <- board.
struct Unknowns {
  std::vector<std::array<double, kIntrinsicCount>> intrinsics;
  std::vector<Pose> cameras;
  std::vector<Pose> boards;  // per instant; on a turntable derived from the holders
  std::vector<bool> board_seen;
  // On a turntable: the reference is the world (the turntable frame at
  // angle 0) and the board's poses follow from its holders' (turntable <-
  // board as yaw, tilt_x, tilt_y and a translation) and the angles.
  const TurntableMotion* motion = nullptr;
  std::vector<std::array<double, 3>> holder_angles, holder_t;
};

Pose HolderPose(const Unknowns& u, std::size_t holder) {
  Eigen::Matrix3d r;
  const double zero[3] = {0, 0, 0};
  for (int axis = 0; axis < 3; ++axis) {
    double unit[3] = {0, 0, 0}, out[3];
    unit[axis] = 1;
    HolderToTurntable(u.holder_angles[holder].data(), zero, unit, out);
    r.col(axis) = Eigen::Vector3d(out[0], out[1], out[2]);
  }
  const auto& t = u.holder_t[holder];
  return FromMatrix(r, Eigen::Vector3d(t[0], t[1], t[2]));
}

// The boards' poses at every instant from the holders' and the angles.
void DeriveBoardPoses(Unknowns* u) {
  if (!u->motion) return;
  for (std::size_t i = 0; i < u->boards.size(); ++i) {
    const Pose turn = FromMatrix(Eigen::AngleAxisd(u->motion->angle_rad[i], Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                                 Eigen::Vector3d::Zero());
    u->boards[i] = Compose(turn, HolderPose(*u, static_cast<std::size_t>(u->motion->holder[i])));
  }
}

struct SolveSummary {
  double cost = 0;  // half the sum of squared residuals
  int residuals = 0;
  int tangent_parameters = 0;
};

// fx fy cx cy in units of the focal length F; k1 k2 k3 and p1 p2 in the
// units that move a point at the image's corner (normalized radius r) by
// one pixel: 1 / (F r^3), 1 / (F r^5), 1 / (F r^7), 1 / (F r^2).
IntrinsicUnits UnitsOf(const std::array<double, kIntrinsicCount>& k, double corner_radius_px) {
  const double f = k[0], r = std::max(corner_radius_px / f, 1e-3);
  return {f, f, f, f, 1 / (f * std::pow(r, 3)), 1 / (f * std::pow(r, 5)), 1 / (f * r * r), 1 / (f * r * r),
          1 / (f * std::pow(r, 7))};
}

// Physical-unit covariances of one camera's parameters.
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
               const std::vector<double>& corner_radius)
      : unknowns_(unknowns), scaled_(*unknowns) {
    for (std::size_t c = 0; c < scaled_.intrinsics.size(); ++c) {
      units_.push_back(UnitsOf(unknowns_->intrinsics[c], corner_radius[c]));
      for (std::size_t i = 0; i < kIntrinsicCount; ++i) scaled_.intrinsics[c][i] /= units_[c][i];
    }
    for (Pose& pose : scaled_.cameras) {
      for (double& t : pose.t) t /= kLengthUnitMm;
    }
    for (Pose& pose : scaled_.boards) {
      for (double& t : pose.t) t /= kLengthUnitMm;
    }
    for (auto& t : scaled_.holder_t) {
      for (double& v : t) v /= kLengthUnitMm;
    }
    ceres::Problem::Options problem_options;
    problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    problem_options.loss_function_ownership = ceres::TAKE_OWNERSHIP;
    problem_ = std::make_unique<ceres::Problem>(problem_options);
    for (const Observation& o : observations) {
      if (!o.inlier) continue;
      const auto c = static_cast<std::size_t>(o.camera);
      const auto i = static_cast<std::size_t>(o.instant);
      ceres::LossFunction* loss = huber_px > 0 ? new ceres::HuberLoss(huber_px) : nullptr;
      Pose& camera = scaled_.cameras[c];
      if (scaled_.motion) {
        const auto h = static_cast<std::size_t>(scaled_.motion->holder[i]);
        auto* cost = new ceres::AutoDiffCostFunction<TurntableCornerResidual, 2, kIntrinsicCount, 4, 3, 3, 3>(
            new TurntableCornerResidual{o.pixel, o.board_point / kLengthUnitMm, units_[c],
                                        scaled_.motion->angle_rad[i]});
        problem_->AddResidualBlock(cost, loss, scaled_.intrinsics[c].data(), camera.q.data(), camera.t.data(),
                                   scaled_.holder_angles[h].data(), scaled_.holder_t[h].data());
      } else {
        auto* cost = new ceres::AutoDiffCostFunction<CornerResidual, 2, kIntrinsicCount, 4, 3, 4, 3>(
            new CornerResidual{o.pixel, o.board_point / kLengthUnitMm, units_[c]});
        Pose& board = scaled_.boards[i];
        problem_->AddResidualBlock(cost, loss, scaled_.intrinsics[c].data(), camera.q.data(), camera.t.data(),
                                   board.q.data(), board.t.data());
      }
      summary_.residuals += 2;
    }
    for (std::size_t c = 0; c < scaled_.cameras.size(); ++c) {
      Pose& camera = scaled_.cameras[c];
      if (!problem_->HasParameterBlock(camera.q.data())) continue;
      problem_->AddResidualBlock(new ceres::AutoDiffCostFunction<DistortionPrior, 5, kIntrinsicCount>(new DistortionPrior),
                                 nullptr, scaled_.intrinsics[c].data());
      problem_->SetManifold(camera.q.data(), &quaternion_);
      if (c == 0 && !scaled_.motion) {  // the reference frame: the gauge
        problem_->SetParameterBlockConstant(camera.q.data());
        problem_->SetParameterBlockConstant(camera.t.data());
      } else {
        summary_.tangent_parameters += 6;
      }
      summary_.tangent_parameters += kIntrinsicCount;
    }
    for (Pose& board : scaled_.boards) {
      if (!problem_->HasParameterBlock(board.q.data())) continue;
      problem_->SetManifold(board.q.data(), &quaternion_);
      summary_.tangent_parameters += 6;
    }
    for (std::size_t h = 0; h < scaled_.holder_angles.size(); ++h) {
      if (!problem_->HasParameterBlock(scaled_.holder_angles[h].data())) continue;
      summary_.tangent_parameters += 6;
      if (h != 0) continue;
      // The world's gauge: the first holder's board has yaw 0 (it sets the
      // world's x axis) and its surface lies at its known height.
      problem_->SetManifold(scaled_.holder_angles[h].data(), &fixed_first_);
      problem_->SetManifold(scaled_.holder_t[h].data(), &fixed_third_);
      summary_.tangent_parameters -= 2;
    }
  }

  SolveSummary Solve() {
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_SCHUR;
    options.max_num_iterations = 200;
    options.function_tolerance = 1e-12;
    options.parameter_tolerance = 1e-12;
    options.num_threads = 2;
    ceres::Solver::Summary summary;
    ceres::Solve(options, problem_.get(), &summary);
    summary_.cost = summary.final_cost;
    *unknowns_ = scaled_;
    for (std::size_t c = 0; c < unknowns_->intrinsics.size(); ++c) {
      for (std::size_t i = 0; i < kIntrinsicCount; ++i) unknowns_->intrinsics[c][i] *= units_[c][i];
    }
    for (Pose& pose : unknowns_->cameras) {
      for (double& t : pose.t) t *= kLengthUnitMm;
    }
    for (Pose& pose : unknowns_->boards) {
      for (double& t : pose.t) t *= kLengthUnitMm;
    }
    for (auto& t : unknowns_->holder_t) {
      for (double& v : t) v *= kLengthUnitMm;
    }
    DeriveBoardPoses(unknowns_);
    return summary_;
  }

  // (J^T J)^-1 at the solution for every camera, in physical units (not yet
  // scaled by the residual variance); false when J^T J is singular to
  // working precision (some parameter is not observed at all).
  bool Covariances(std::vector<CameraCovariance>* out) {
    ceres::Covariance::Options options;
    options.algorithm_type = summary_.tangent_parameters <= 2000 ? ceres::DENSE_SVD : ceres::SPARSE_QR;
    // DENSE_SVD factors J itself, whose singular values it resolves to about
    // 1e-10 of the largest (1e-20 for J^T J): a narrow lens's focal length
    // and distance are that weakly tied, and get a large sigma, not none.
    options.min_reciprocal_condition_number = 1e-20;
    options.num_threads = 2;
    ceres::Covariance covariance(options);
    std::vector<std::pair<const double*, const double*>> blocks;
    for (std::size_t c = 0; c < scaled_.cameras.size(); ++c) {
      const double* k = scaled_.intrinsics[c].data();
      blocks.emplace_back(k, k);
      if (c == 0 && !scaled_.motion) continue;
      const double* q = scaled_.cameras[c].q.data();
      const double* t = scaled_.cameras[c].t.data();
      for (const auto& pair : {std::pair{q, q}, std::pair{t, t}, std::pair{k, q}, std::pair{k, t}, std::pair{q, t}}) {
        blocks.push_back(pair);
      }
    }
    if (!covariance.Compute(blocks, problem_.get())) {
      return false;
    }
    out->resize(scaled_.cameras.size());
    for (std::size_t c = 0; c < scaled_.cameras.size(); ++c) {
      // The solver's units back to physical ones, parameter by parameter.
      Eigen::Matrix<double, kCameraParameters, 1> units;
      units.head<kIntrinsicCount>() = Eigen::Matrix<double, kIntrinsicCount, 1>(units_[c].data());
      // Ceres' QuaternionManifold turns by twice its tangent: a tangent
      // delta is the rotation vector 2 delta.
      units.segment<3>(kIntrinsicCount).setConstant(2.0);
      units.tail<3>().setConstant(kLengthUnitMm);
      Eigen::Matrix<double, kCameraParameters, kCameraParameters> joint;
      joint.setZero();
      const double* k = scaled_.intrinsics[c].data();
      Eigen::Matrix<double, kIntrinsicCount, kIntrinsicCount, Eigen::RowMajor> kk;
      covariance.GetCovarianceBlock(k, k, kk.data());
      joint.topLeftCorner<kIntrinsicCount, kIntrinsicCount>() = kk;
      if (c != 0 || scaled_.motion) {
        const double* q = scaled_.cameras[c].q.data();
        const double* t = scaled_.cameras[c].t.data();
        Eigen::Matrix<double, 3, 3, Eigen::RowMajor> qq, tt, qt;
        Eigen::Matrix<double, kIntrinsicCount, 3, Eigen::RowMajor> kq, kt;
        covariance.GetCovarianceBlockInTangentSpace(q, q, qq.data());
        covariance.GetCovarianceBlock(t, t, tt.data());
        covariance.GetCovarianceBlockInTangentSpace(k, q, kq.data());
        covariance.GetCovarianceBlockInTangentSpace(k, t, kt.data());
        covariance.GetCovarianceBlockInTangentSpace(q, t, qt.data());
        constexpr int r0 = kIntrinsicCount, c0 = kIntrinsicCount + 3;
        joint.block<3, 3>(r0, r0) = qq;
        joint.block<3, 3>(c0, c0) = tt;
        joint.block<kIntrinsicCount, 3>(0, r0) = kq;
        joint.block<kIntrinsicCount, 3>(0, c0) = kt;
        joint.block<3, 3>(r0, c0) = qt;
        joint.block<3, kIntrinsicCount>(r0, 0) = kq.transpose();
        joint.block<3, kIntrinsicCount>(c0, 0) = kt.transpose();
        joint.block<3, 3>(c0, r0) = qt.transpose();
      }
      (*out)[c].joint = units.asDiagonal() * joint * units.asDiagonal();
    }
    return true;
  }

 private:
  Unknowns* unknowns_;
  Unknowns scaled_;
  std::vector<IntrinsicUnits> units_;
  ceres::QuaternionManifold quaternion_;
  ceres::SubsetManifold fixed_first_{3, {0}};
  ceres::SubsetManifold fixed_third_{3, {2}};
  std::unique_ptr<ceres::Problem> problem_;
  SolveSummary summary_;
};

Eigen::Vector2d Residual(const Unknowns& u, const Observation& o) {
  const CornerResidual residual{o.pixel, o.board_point};
  const Pose& camera = u.cameras[static_cast<std::size_t>(o.camera)];
  const Pose& board = u.boards[static_cast<std::size_t>(o.instant)];
  double r[2];
  residual(u.intrinsics[static_cast<std::size_t>(o.camera)].data(), camera.q.data(), camera.t.data(), board.q.data(),
           board.t.data(), r);
  return {r[0], r[1]};
}

Eigen::Vector3d InCamera(const Unknowns& u, const Observation& o) {
  const Pose& camera = u.cameras[static_cast<std::size_t>(o.camera)];
  const Pose& board = u.boards[static_cast<std::size_t>(o.instant)];
  const Eigen::Vector3d in_reference =
      Rotation(board) * o.board_point + Eigen::Vector3d(board.t[0], board.t[1], board.t[2]);
  return Rotation(camera).transpose() * (in_reference - Eigen::Vector3d(camera.t[0], camera.t[1], camera.t[2]));
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
    const Eigen::Matrix3d r =
        (turn.norm() > 0 ? Eigen::AngleAxisd(turn.norm(), turn.normalized()).toRotationMatrix()
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
                         : p < kIntrinsicCount + 3 ? 1.0 : 100.0;
    Eigen::Matrix<double, kCameraParameters, 1> delta = Eigen::Matrix<double, kCameraParameters, 1>::Zero();
    delta[p] = 1e-7 * scale;
    jacobian.col(p) = (project(delta) - project(-delta)) / (2e-7 * scale);
  }
  const Eigen::Matrix2d projected = jacobian * used * jacobian.transpose();
  return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(projected).eigenvalues().maxCoeff()));
}

// The turntable's axis from the free solution's board poses (reference =
// the first camera): the board's motion between two angles on one holder is
// a rotation about the axis by their difference. Then everything moves into
// the world frame TurntableMotion defines. Conditioning: the axis comes from
// pairs of angles at least 5 degrees apart; a holder seen at one angle only
// gives its pose, not the axis.
void InitTurntable(Unknowns* u, const TurntableMotion& motion) {
  std::vector<std::size_t> seen;
  for (std::size_t i = 0; i < u->boards.size(); ++i) {
    if (u->board_seen[i]) seen.push_back(i);
  }
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  Eigen::MatrixXd a(0, 3);
  Eigen::VectorXd b(0);
  for (std::size_t x = 0; x < seen.size(); ++x) {
    for (std::size_t y = x + 1; y < seen.size(); ++y) {
      const std::size_t i = seen[x], j = seen[y];
      if (motion.holder[i] != motion.holder[j]) continue;
      const double turn = motion.angle_rad[j] - motion.angle_rad[i];
      if (std::abs(std::sin(turn)) < std::sin(5.0 / kRadToDeg)) continue;
      const Pose m = Compose(u->boards[j], Inverse(u->boards[i]));
      const Eigen::AngleAxisd rotation(Rotation(m));
      direction += rotation.axis() * (rotation.angle() * turn > 0 ? 1.0 : -1.0) * std::abs(std::sin(rotation.angle()));
      // (I - R) p = t for every point p on the axis.
      a.conservativeResize(a.rows() + 3, 3);
      b.conservativeResize(b.rows() + 3);
      a.bottomRows(3) = Eigen::Matrix3d::Identity() - Rotation(m);
      b.tail(3) = Eigen::Vector3d(m.t[0], m.t[1], m.t[2]);
    }
  }
  if (direction.norm() < 1e-9) {
    throw core::Error(
        "the turntable's axis cannot be found: the board was not seen on one holder at two turntable angles at "
        "least 5 degrees apart");
  }
  const Eigen::Vector3d z = direction.normalized();
  const Eigen::Vector3d point = a.completeOrthogonalDecomposition().solve(b);
  // The origin: on the axis, board_height_mm below the first holder's board.
  std::size_t first = seen.size();
  for (std::size_t x = 0; x < seen.size() && first == seen.size(); ++x) {
    if (motion.holder[seen[x]] == 0) first = seen[x];
  }
  if (first == seen.size()) throw core::Error("the board was never seen on the first holder tilt");
  const Pose& board0 = u->boards[first];
  const Eigen::Vector3d board_origin(board0.t[0], board0.t[1], board0.t[2]);
  const Eigen::Vector3d origin = point + ((board_origin - point).dot(z) - motion.board_height_mm) * z;
  const Eigen::Vector3d board_x = Eigen::AngleAxisd(-motion.angle_rad[first], z) * (Rotation(board0) * Eigen::Vector3d::UnitX());
  const Eigen::Vector3d x = (board_x - board_x.dot(z) * z).normalized();
  Eigen::Matrix3d world_axes;
  world_axes << x, z.cross(x), z;
  const Pose world_from_reference = Inverse(FromMatrix(world_axes, origin));
  for (Pose& camera : u->cameras) camera = Compose(world_from_reference, camera);
  int holders = 0;
  for (const int h : motion.holder) holders = std::max(holders, h + 1);
  u->holder_angles.assign(static_cast<std::size_t>(holders), {0, 0, 0});
  u->holder_t.assign(static_cast<std::size_t>(holders), {0, 0, motion.board_height_mm});
  std::vector<bool> placed(static_cast<std::size_t>(holders), false);
  for (const std::size_t i : seen) {
    const auto h = static_cast<std::size_t>(motion.holder[i]);
    if (placed[h]) continue;
    placed[h] = true;
    // turntable <- board = Rz(-angle) (world <- reference) (reference <- board)
    const Pose unturn = FromMatrix(Eigen::AngleAxisd(-motion.angle_rad[i], Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                                   Eigen::Vector3d::Zero());
    const Pose on_table = Compose(unturn, Compose(world_from_reference, u->boards[i]));
    const Eigen::Matrix3d r = Rotation(on_table);
    const double pitch = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
    const double roll = std::atan2(r(2, 1), r(2, 2));
    u->holder_angles[h] = {h == 0 ? 0.0 : std::atan2(r(1, 0), r(0, 0)), roll, pitch};
    u->holder_t[h] = {on_table.t[0], on_table.t[1], h == 0 ? motion.board_height_mm : on_table.t[2]};
  }
  for (std::size_t h = 0; h < placed.size(); ++h) {
    if (!placed[h]) throw core::Error("the board was never seen on holder tilt " + std::to_string(h));
  }
  u->motion = &motion;
  DeriveBoardPoses(u);
}

}  // namespace

Eigen::Vector2d ProjectInCamera(const formats::CameraCalibration& camera, const Eigen::Vector3d& point) {
  const std::array<double, kIntrinsicCount> k = IntrinsicArray(camera);
  double uv[2];
  ProjectOpenCv(k.data(), point.data(), uv);
  return {uv[0], uv[1]};
}

Eigen::Vector3d UnprojectAtDepth(const formats::CameraCalibration& camera, const Eigen::Vector2d& pixel, double z) {
  const cv::Matx33d matrix(camera.intrinsics.fx, 0, camera.intrinsics.cx, 0, camera.intrinsics.fy,
                           camera.intrinsics.cy, 0, 0, 1);
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

CameraCalibrationResult CalibrateCameras(const CalibrationBoard& board, const std::vector<CameraViews>& cameras,
                                         const CameraCalibrationOptions& options, const TurntableMotion* motion) {
  if (const core::CheckResult problem = options.Check(); !problem.empty()) {
    throw core::Error("camera calibration: " + problem);
  }
  if (cameras.empty()) throw core::Error("camera calibration: no camera");
  const std::size_t instants = cameras[0].detections.size();
  for (const CameraViews& c : cameras) {
    if (c.detections.size() != instants || c.names.size() != instants ||
        (!c.qualities.empty() && c.qualities.size() != instants)) {
      throw core::Error("camera calibration: camera " + core::Quoted(c.id) + " has " +
                        std::to_string(c.detections.size()) + " photos, expected " + std::to_string(instants));
    }
  }
  CameraCalibrationResult result;
  result.cameras.resize(cameras.size());

  // Which photos are usable, and why the others are not.
  std::vector<std::vector<bool>> usable(cameras.size(), std::vector<bool>(instants, false));
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const CameraViews& views = cameras[c];
    CalibratedCamera& out = result.cameras[c];
    for (std::size_t i = 0; i < instants; ++i) {
      const BoardDetection& d = views.detections[i];
      if (d.empty()) {
        out.unused_images.push_back({views.names[i], "board not found"});
        continue;
      }
      if (static_cast<int>(d.size()) < options.min_corners_per_view) {
        out.unused_images.push_back({views.names[i], "only " + std::to_string(d.size()) + " corners found (" +
                                                         std::to_string(options.min_corners_per_view) + " needed)"});
        continue;
      }
      if (!views.qualities.empty()) {
        const DetectionQuality& q = views.qualities[i];
        if (q.saturated_fraction > options.max_saturated_fraction) {
          out.outlier_images.push_back({views.names[i], "saturated: " + core::Fixed(100 * q.saturated_fraction, 1) +
                                                            " % of the board's pixels at full scale"});
          continue;
        }
        if (q.edge_width_px > options.max_edge_width_px) {
          out.outlier_images.push_back({views.names[i], "blurred: the board's edges are " +
                                                            core::Fixed(q.edge_width_px, 1) + " px wide (at most " +
                                                            core::Fixed(options.max_edge_width_px, 1) + ")"});
          continue;
        }
      }
      usable[c][i] = true;
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

  // Zhang's method per camera: intrinsics and each view's camera <- board.
  Unknowns unknowns;
  unknowns.intrinsics.resize(cameras.size());
  unknowns.cameras.resize(cameras.size());
  unknowns.boards.resize(instants);
  unknowns.board_seen.assign(instants, false);
  std::vector<std::map<std::size_t, Pose>> camera_from_board(cameras.size());
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
      throw core::Error("camera " + core::Quoted(cameras[c].id) + ": Zhang's initial calibration failed: " +
                        core::Cut(e.what()));
    }
    unknowns.intrinsics[c] = {matrix.at<double>(0, 0), matrix.at<double>(1, 1), matrix.at<double>(0, 2),
                              matrix.at<double>(1, 2), distortion.at<double>(0), distortion.at<double>(1),
                              distortion.at<double>(2), distortion.at<double>(3), 0.0};
    for (std::size_t v = 0; v < views.size(); ++v) {
      camera_from_board[c][views[v]] = FromRvecTvec(rvecs[v], tvecs[v]);
    }
  }

  // Cameras' poses in the first camera's frame, through shared instants
  // (breadth first, each link through the instant where both see the most).
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
      unknowns.cameras[c] = Compose(Compose(unknowns.cameras[known], camera_from_board[known][best]),
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
      unknowns.boards[i] = Compose(unknowns.cameras[c], found->second);
      unknowns.board_seen[i] = true;
      break;
    }
  }

  std::vector<double> corner_radius;
  for (const CameraViews& c : cameras) corner_radius.push_back(0.5 * std::hypot(c.width, c.height));
  std::vector<Observation> observations;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    for (std::size_t i = 0; i < instants; ++i) {
      if (!usable[c][i]) continue;
      const BoardDetection& d = cameras[c].detections[i];
      for (std::size_t j = 0; j < d.size(); ++j) {
        observations.push_back({static_cast<int>(c), static_cast<int>(i), d.pixels[j], board.CornerPosition(d.ids[j])});
      }
    }
  }

  if (motion) {
    if (const core::CheckResult problem = motion->Check(instants); !problem.empty()) {
      throw core::Error("camera calibration: " + problem);
    }
    BoardProblem(&unknowns, observations, options.huber_px, corner_radius).Solve();
    InitTurntable(&unknowns, *motion);
  }

  // Robust solve, then outliers: corners far beyond the rest, then photos
  // that fit much worse than the median photo.
  BoardProblem(&unknowns, observations, options.huber_px, corner_radius).Solve();
  std::vector<double> squared;
  for (const Observation& o : observations) squared.push_back(Residual(unknowns, o).squaredNorm());
  // A 2D residual with per-coordinate sigma s has median squared norm
  // 2 ln 2 s^2.
  const double robust_sigma = std::sqrt(Median(squared) / (2 * std::log(2.0)));
  const double corner_limit = std::max(options.outlier_corner_sigmas * robust_sigma, 0.25);
  int outliers = 0;
  for (std::size_t n = 0; n < observations.size(); ++n) {
    if (std::sqrt(squared[n]) > corner_limit) {
      observations[n].inlier = false;
      ++outliers;
      ++result.cameras[static_cast<std::size_t>(observations[n].camera)].outlier_corners;
    }
  }
  const auto fit_text = [&](double rms) {
    return "reprojection RMS " + core::Fixed(rms, 2) + " px over " + std::to_string(observations.size()) + " corners";
  };
  if (outliers > options.max_outlier_fraction * static_cast<double>(observations.size())) {
    double sum = 0;
    for (const double s : squared) sum += s;
    throw core::Error("the board " + core::Quoted(board.Spec()) + " does not fit the photos: " +
                      fit_text(std::sqrt(sum / static_cast<double>(observations.size()))) + ", " +
                      std::to_string(outliers) + " of them beyond " + core::Fixed(corner_limit, 2) +
                      " px; check the board's size, squares and dictionary");
  }
  std::map<std::pair<int, int>, std::pair<double, int>> per_photo;  // (camera, instant) -> (sum, count)
  for (std::size_t n = 0; n < observations.size(); ++n) {
    if (!observations[n].inlier) continue;
    auto& entry = per_photo[{observations[n].camera, observations[n].instant}];
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
    usable[static_cast<std::size_t>(c)][static_cast<std::size_t>(i)] = false;
    result.cameras[static_cast<std::size_t>(c)].outlier_images.push_back(
        {cameras[static_cast<std::size_t>(c)].names[static_cast<std::size_t>(i)],
         "reprojection RMS " + core::Fixed(rms, 2) + " px, " + core::Fixed(rms / median_photo_rms, 1) +
             " times the median photo's"});
    for (Observation& o : observations) {
      if (o.camera == c && o.instant == i) o.inlier = false;
    }
  }
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const int count = static_cast<int>(std::count(usable[c].begin(), usable[c].end(), true));
    if (count < options.min_views_per_camera) {
      throw core::Error("camera " + core::Quoted(cameras[c].id) + " keeps only " + std::to_string(count) +
                        " photos after outliers are set aside; at least " +
                        std::to_string(options.min_views_per_camera) + " are needed");
    }
  }

  // Least squares on the inliers, and its covariance.
  BoardProblem final_problem(&unknowns, observations, 0.0, corner_radius);
  const SolveSummary solved = final_problem.Solve();
  const int dof = solved.residuals - solved.tangent_parameters;
  if (dof <= 0) {
    throw core::Error("camera calibration: " + std::to_string(solved.residuals / 2) + " corners cannot determine " +
                      std::to_string(solved.tangent_parameters) + " parameters; take more photos");
  }
  const double variance = 2 * solved.cost / dof;
  result.residual_sigma_px = std::sqrt(variance);

  std::vector<CameraCovariance> covariances;
  const bool have_covariance = final_problem.Covariances(&covariances);
  if (!have_covariance) {
    result.warnings.push_back(
        "the parameters' covariance could not be computed (J^T J is singular to working precision: some "
        "parameters, such as the focal length with every photo square to the camera, are not observed); no "
        "uncertainty is reported and the values are not to be trusted");
  }

  for (std::size_t c = 0; c < cameras.size(); ++c) {
    CalibratedCamera& out = result.cameras[c];
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
    if (!have_covariance) continue;
    const Eigen::Matrix<double, kIntrinsicCount, kIntrinsicCount> k_cov = variance * covariances[c].intrinsics();
    const Eigen::Matrix<double, kIntrinsicCount, 1> k_std = k_cov.diagonal().cwiseSqrt();
    formats::CameraCalibration& cal = out.calibration;
    cal.intrinsics.uncertainty = {k_std[0], k_std[1], k_std[2], k_std[3]};
    cal.distortion.uncertainty = {k_std[4], k_std[5], k_std[6], k_std[7], k_std[8]};
    out.projection_uncertainty_px = ProjectionSigma(unknowns, c, variance * covariances[c].joint, motion != nullptr,
                                                    out.working_distance_mm);
    for (const int f : {0, 1}) {
      const double relative = k_std[f] / unknowns.intrinsics[c][static_cast<std::size_t>(f)];
      if (relative > options.warn_relative_focal_sigma) {
        result.warnings.push_back(
            "camera " + core::Quoted(cameras[c].id) + ": focal length poorly observed (" + kIntrinsicNames[f] + " " +
            core::Fixed(unknowns.intrinsics[c][static_cast<std::size_t>(f)], 1) + " +- " + core::Fixed(k_std[f], 1) +
            " px, " + core::Fixed(100 * relative, 2) + " %): tilt the board more between photos");
        break;
      }
    }
    if (c == 0 && !motion) continue;
    cal.pose.uncertainty.rotation_rad = (variance * covariances[c].rotation().diagonal()).cwiseSqrt();
    cal.pose.uncertainty.translation_mm = (variance * covariances[c].centre().diagonal()).cwiseSqrt();
  }
  for (std::size_t c = 1; c < cameras.size(); ++c) {
    const formats::CameraCalibration& cal = result.cameras[c].calibration;
    RelativePose relative;
    relative.from = cameras[0].id;
    relative.to = cameras[c].id;
    const Pose first_from_c = Compose(Inverse(unknowns.cameras[0]), unknowns.cameras[c]);
    double aa[3];
    ceres::QuaternionToAngleAxis(first_from_c.q.data(), aa);
    relative.rotation_deg = Eigen::Vector3d(aa[0], aa[1], aa[2]) * kRadToDeg;
    relative.translation_mm = Eigen::Vector3d(first_from_c.t[0], first_from_c.t[1], first_from_c.t[2]);
    if (!motion && cal.pose.uncertainty.rotation_rad) {
      relative.rotation_std_deg = *cal.pose.uncertainty.rotation_rad * kRadToDeg;
      relative.translation_std_mm = *cal.pose.uncertainty.translation_mm;
      relative.has_std = true;
    }
    result.relative_poses.push_back(relative);
  }
  for (std::size_t h = 0; motion && h < unknowns.holder_angles.size(); ++h) {
    const Pose pose = HolderPose(unknowns, h);
    core::RigidTransform holder;
    holder.parent_frame = "turntable";
    holder.child_frame = "board";
    holder.rotation = Rotation(pose);
    holder.translation = Eigen::Vector3d(pose.t[0], pose.t[1], pose.t[2]);
    result.holder_poses.push_back(holder);
  }
  for (const CalibratedCamera& c : result.cameras) {
    if (c.rms_px > options.max_rms_px) {
      throw core::Error("the board " + core::Quoted(board.Spec()) + " does not fit the photos of camera " +
                        core::Quoted(c.calibration.id) + ": reprojection RMS " + core::Fixed(c.rms_px, 2) +
                        " px over " + std::to_string(c.corners_used) + " corners (at most " +
                        core::Fixed(options.max_rms_px, 2) +
                        " px expected); check the board's size, squares and dictionary");
    }
  }
  return result;
}

}  // namespace mesocap::calibration
