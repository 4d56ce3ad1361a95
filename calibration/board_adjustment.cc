#include "calibration/board_adjustment.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace mesocap::calibration::board_adjustment {
namespace {

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
using IntrinsicUnits = Intrinsics;

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
  bool operator()(const T* scaled_k, const T* camera_q, const T* camera_c, const T* holder_angles, const T* holder_t,
                  T* residual) const {
    const T point[3] = {T(board_point.x()), T(board_point.y()), T(board_point.z())};
    T on_table[3];
    HolderToTurntable(holder_angles, holder_t, point, on_table);
    const T c(std::cos(angle_rad)), s(std::sin(angle_rad));
    const T in_world[3] = {c * on_table[0] - s * on_table[1], s * on_table[0] + c * on_table[1], on_table[2]};
    ReprojectionResidual(scaled_k, units, camera_q, camera_c, in_world, observed, residual);
    return true;
  }
};

// The boards' poses at every instant from the holders' and the angles.
void DeriveBoardPoses(Unknowns* u) {
  if (!u->motion) return;
  for (std::size_t i = 0; i < u->boards.size(); ++i) {
    const Pose turn =
        FromMatrix(Eigen::AngleAxisd(u->motion->angle_rad[i], Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                   Eigen::Vector3d::Zero());
    u->boards[i] = Compose(turn, HolderPose(*u, static_cast<std::size_t>(u->motion->holder[i])));
  }
}

// fx fy cx cy in units of the focal length F; k1 k2 k3 and p1 p2 in the
// units that move a point at the image's corner (normalized radius r) by
// one pixel: 1 / (F r^3), 1 / (F r^5), 1 / (F r^7), 1 / (F r^2).
IntrinsicUnits UnitsOf(const std::array<double, kIntrinsicCount>& k, double corner_radius_px) {
  const double f = k[0], r = std::max(corner_radius_px / f, 1e-3);
  return {f,
          f,
          f,
          f,
          1 / (f * std::pow(r, 3)),
          1 / (f * std::pow(r, 5)),
          1 / (f * r * r),
          1 / (f * r * r),
          1 / (f * std::pow(r, 7))};
}

}  // namespace

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
  const Eigen::Vector3d t =
      Rotation(a) * Eigen::Vector3d(b.t[0], b.t[1], b.t[2]) + Eigen::Vector3d(a.t[0], a.t[1], a.t[2]);
  return FromMatrix(Rotation(a) * Rotation(b), t);
}

Pose Inverse(const Pose& a) {
  const Eigen::Matrix3d r = Rotation(a).transpose();
  return FromMatrix(r, -r * Eigen::Vector3d(a.t[0], a.t[1], a.t[2]));
}

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

BoardProblem::BoardProblem(Unknowns* unknowns, const std::vector<Observation>& observations, double huber_px,
                           const std::vector<double>& corner_radius)
    : unknowns_(unknowns), scaled_(*unknowns) {
  scaled_.models.resize(scaled_.intrinsics.size(), DistortionModel::kFull);
  for (std::size_t c = 0; c < scaled_.intrinsics.size(); ++c) {
    units_.push_back(UnitsOf(unknowns_->intrinsics[c], corner_radius[c]));
    for (std::size_t i = 0; i < kIntrinsicCount; ++i) scaled_.intrinsics[c][i] /= units_[c][i];
    for (std::size_t i = kPinholeCount + static_cast<std::size_t>(TermCount(scaled_.models[c])); i < kIntrinsicCount;
         ++i) {
      scaled_.intrinsics[c][i] = 0;
    }
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
          new TurntableCornerResidual{o.pixel, o.board_point / kLengthUnitMm, units_[c], scaled_.motion->angle_rad[i]});
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
    problem_->AddResidualBlock(
        new ceres::AutoDiffCostFunction<DistortionPrior, 5, kIntrinsicCount>(new DistortionPrior), nullptr,
        scaled_.intrinsics[c].data());
    problem_->SetManifold(camera.q.data(), &quaternion_);
    if (ceres::Manifold* held = HeldTerms(scaled_.models[c])) problem_->SetManifold(scaled_.intrinsics[c].data(), held);
    if (c == 0 && !scaled_.motion) {  // the reference frame: the gauge
      problem_->SetParameterBlockConstant(camera.q.data());
      problem_->SetParameterBlockConstant(camera.t.data());
    } else {
      summary_.tangent_parameters += 6;
    }
    summary_.tangent_parameters += kPinholeCount + TermCount(scaled_.models[c]);
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

ceres::Manifold* BoardProblem::HeldTerms(DistortionModel model) {
  switch (model) {
    case DistortionModel::kNone:
      return &no_distortion_;
    case DistortionModel::kK1:
      return &k1_only_;
    case DistortionModel::kK1K2:
      return &k1_k2_only_;
    case DistortionModel::kFull:
      return nullptr;
  }
  return nullptr;
}

SolveSummary BoardProblem::Solve() {
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

bool BoardProblem::Covariances(std::vector<CameraCovariance>* out) {
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
      // The intrinsics' tangent: the pinhole's and the model's terms, the
      // first of the nine; the terms held at zero covary with nothing.
      Eigen::Matrix<double, kIntrinsicCount, 3, Eigen::RowMajor> kq, kt;
      kq.setZero();
      kt.setZero();
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
  const Eigen::Vector3d board_x =
      Eigen::AngleAxisd(-motion.angle_rad[first], z) * (Rotation(board0) * Eigen::Vector3d::UnitX());
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

}  // namespace mesocap::calibration::board_adjustment
