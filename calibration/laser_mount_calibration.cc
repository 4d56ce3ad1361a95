#include "calibration/laser_mount_calibration.h"

#include <ceres/ceres.h>
#include <ceres/sphere_manifold.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "calibration/rig_frames.h"
#include "core/angles.h"

namespace mesocap::calibration {

core::CheckResult LaserMountOptions::Check() const {
  if (!(max_axis_sigma_deg > 0)) return "the tilt axis' largest sigma must be positive degrees";
  if (!(max_source_sigma_mm > 0)) return "the laser source's largest sigma must be positive mm";
  if (!(huber_sigmas > 0)) return "the Huber scale must be positive (plane sigmas)";
  if (!(outlier_sigmas > 1)) return "the outlier threshold must exceed 1 robust sigma";
  return {};
}

namespace {

// A mount's unknowns in the light_arc frame, around its nominal geometry.
struct MountFrame {
  Eigen::Vector3d source;          // nominal
  Eigen::Vector3d b1, b2;          // across the nominal axis
  Eigen::Vector3d nominal_normal;  // at tilt 0
};

// The plane at tilt t in the arc frame: a point on it (on the axis) and its
// normal, for axis direction d, axis offset o and angle phi about the axis.
template <typename T>
void MountPlane(const MountFrame& frame, const T* d_in, const T* o, const T* phi, double tilt,
                Eigen::Matrix<T, 3, 1>* point, Eigen::Matrix<T, 3, 1>* normal) {
  using std::cos;
  using std::sin;
  using V = Eigen::Matrix<T, 3, 1>;
  const V d = V(d_in[0], d_in[1], d_in[2]).normalized();
  *point = frame.source.cast<T>() + o[0] * frame.b1.cast<T>() + o[1] * frame.b2.cast<T>();
  // The nominal normal made perpendicular to the axis, turned about it by phi.
  const V n = frame.nominal_normal.cast<T>();
  const V u = (n - n.dot(d) * d).normalized();
  const V v = d.cross(u);
  const V n0 = cos(phi[0]) * u + sin(phi[0]) * v;
  // Rodrigues' formula for n0 perpendicular to d.
  *normal = std::cos(tilt) * n0 + std::sin(tilt) * d.cross(n0);
}

// One measured plane against its mount's prediction: the anchor's distance
// from the predicted plane over its sigma, and the normal's two components
// across the measured normal over theirs.
struct PlaneResidual {
  MountFrame frame;
  Eigen::Matrix3d world_from_arc;  // rotation; the translation below
  Eigen::Vector3d world_from_arc_t;
  double tilt = 0.0;
  Eigen::Vector3d anchor, e1, e2;  // world
  double position_sigma = 1.0, normal_sigma = 1.0;

  template <typename T>
  bool operator()(const T* d, const T* o, const T* phi, T* r) const {
    Eigen::Matrix<T, 3, 1> point, normal;
    MountPlane(frame, d, o, phi, tilt, &point, &normal);
    const Eigen::Matrix<T, 3, 1> nw = world_from_arc.cast<T>() * normal;
    const Eigen::Matrix<T, 3, 1> pw = world_from_arc.cast<T>() * point + world_from_arc_t.cast<T>();
    r[0] = nw.dot(anchor.cast<T>() - pw) / position_sigma;
    r[1] = nw.dot(e1.cast<T>()) / normal_sigma;
    r[2] = nw.dot(e2.cast<T>()) / normal_sigma;
    return true;
  }
};

// The unknowns of one mount.
struct MountUnknowns {
  std::array<double, 3> axis;
  std::array<double, 2> offset = {0.0, 0.0};
  std::array<double, 1> phi = {0.0};
};

// Solves `u` from the residuals marked in `use`, with a Huber loss of scale
// `huber` (0: least squares); the problem is kept for the covariance.
std::unique_ptr<ceres::Problem> Fit(const std::vector<PlaneResidual>& residuals, const std::vector<bool>& use,
                                    double huber, const std::string& id, MountUnknowns* u,
                                    ceres::Solver::Summary* summary) {
  auto problem = std::make_unique<ceres::Problem>();
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (!use[i]) continue;
    problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<PlaneResidual, 3, 3, 2, 1>(new PlaneResidual(residuals[i])),
        huber > 0 ? new ceres::HuberLoss(huber) : nullptr, u->axis.data(), u->offset.data(), u->phi.data());
  }
  problem->SetManifold(u->axis.data(), new ceres::SphereManifold<3>());
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 200;
  solver.function_tolerance = 1e-14;
  solver.parameter_tolerance = 1e-14;
  ceres::Solve(solver, problem.get(), summary);
  if (!summary->IsSolutionUsable()) {
    throw core::Error("laser mount " + core::Quoted(id) + ": the fit failed: " + summary->message);
  }
  return problem;
}

// The mount the unknowns describe: the source is the nominal one moved
// onto the fitted axis (its place along the axis moves no plane).
void SetMount(const MountFrame& frame, const MountUnknowns& u, formats::LaserMountCalibration* mount) {
  const Eigen::Vector3d d = Eigen::Vector3d(u.axis[0], u.axis[1], u.axis[2]).normalized();
  Eigen::Vector3d point, n0;
  MountPlane(frame, u.axis.data(), u.offset.data(), u.phi.data(), 0.0, &point, &n0);
  mount->tilt_axis = d;
  mount->plane_normal_at_zero_tilt = n0;
  mount->source_mm = point + (frame.source - point).dot(d) * d;
}

// The distinct tilts (nano-radians) of the planes marked in `use`.
std::size_t CountTilts(const std::vector<const LaserPlaneObservation*>& seen, const std::vector<bool>& use) {
  std::set<long long> tilts;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (use[i]) tilts.insert(std::llround(seen[i]->tilt_rad * 1e9));
  }
  return tilts.size();
}

// The planes measured of each mount, in the order given.
std::map<int, std::vector<const LaserPlaneObservation*>> LaserPlanesOfEachMount(
    const formats::Calibration& geometry, const std::vector<LaserPlaneObservation>& planes) {
  std::map<int, std::vector<const LaserPlaneObservation*>> of_mount;
  for (const LaserPlaneObservation& p : planes) {
    if (p.mount < 0 || p.mount >= static_cast<int>(geometry.laser_mounts.size())) {
      throw core::Error(p.name + ": laser mount " + std::to_string(p.mount) + " is not in the calibration");
    }
    of_mount[p.mount].push_back(&p);
  }
  return of_mount;
}

// The frame of a mount's unknowns: its nominal source and normal, and two
// directions across its nominal axis.
MountFrame NominalMountFrame(const formats::LaserMountCalibration& nominal) {
  MountFrame frame;
  frame.source = nominal.source_mm;
  frame.nominal_normal = nominal.plane_normal_at_zero_tilt.normalized();
  const Eigen::Vector3d nominal_axis = nominal.tilt_axis.normalized();
  frame.b1 = nominal_axis.unitOrthogonal();
  frame.b2 = nominal_axis.cross(frame.b1);
  return frame;
}

// Each plane of mount `m` against its prediction, in the world frame of the
// arc angle it was measured at.
std::vector<PlaneResidual> MountPlaneResiduals(const formats::Calibration& geometry, std::size_t m,
                                               const MountFrame& frame,
                                               const std::vector<const LaserPlaneObservation*>& seen) {
  std::vector<PlaneResidual> residuals;
  for (const LaserPlaneObservation* p : seen) {
    PlaneResidual r;
    r.frame = frame;
    for (int i = 0; i < 3; ++i) {
      r.world_from_arc.col(i) = LightArcDirectionToWorld(geometry.light_arc, p->arc_rad, Eigen::Vector3d::Unit(i));
    }
    r.world_from_arc_t = LightArcPointToWorld(geometry.light_arc, p->arc_rad, Eigen::Vector3d::Zero());
    r.tilt = p->tilt_rad;
    r.anchor = p->fit.anchor;
    // The measured normal's sign is arbitrary: take the nominal one's.
    const Eigen::Vector3d predicted = MountInWorld(geometry, static_cast<int>(m), p->arc_rad, p->tilt_rad).normal;
    const Eigen::Vector3d n = p->fit.plane.normal.dot(predicted) < 0 ? -p->fit.plane.normal : p->fit.plane.normal;
    r.e1 = n.unitOrthogonal();
    r.e2 = n.cross(r.e1);
    r.position_sigma = std::max(p->fit.position_sigma_mm, 1e-6);
    r.normal_sigma = std::max(p->fit.normal_sigma_rad, 1e-9);
    residuals.push_back(r);
  }
  return residuals;
}

// A plane's three residuals (in its sigmas) for the unknowns `u`.
std::array<double, 3> EvaluatePlaneResidual(const PlaneResidual& residual, const MountUnknowns& u) {
  std::array<double, 3> e;
  residual(u.axis.data(), u.offset.data(), u.phi.data(), e.data());
  return e;
}

// A robust (Huber) solve; outliers beyond outlier_sigmas robust sigmas (the
// residuals' median absolute value, at least the planes' own sigmas) are
// marked out of `inlier` and reported in `left_out`.
void LeaveOutOutlierPlanes(const std::vector<PlaneResidual>& residuals,
                           const std::vector<const LaserPlaneObservation*>& seen, const std::string& id,
                           const LaserMountOptions& options, MountUnknowns* u, ceres::Solver::Summary* summary,
                           std::vector<bool>* inlier, std::vector<SetAsideImage>* left_out) {
  Fit(residuals, *inlier, options.huber_sigmas, id, u, summary);
  std::vector<double> magnitudes, worst(residuals.size());
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    const std::array<double, 3> e = EvaluatePlaneResidual(residuals[i], *u);
    worst[i] = std::max({std::abs(e[0]), std::abs(e[1]), std::abs(e[2])});
    for (double v : e) magnitudes.push_back(std::abs(v));
  }
  std::nth_element(magnitudes.begin(), magnitudes.begin() + static_cast<std::ptrdiff_t>(magnitudes.size() / 2),
                   magnitudes.end());
  const double robust_sigma = std::max(1.0, 1.4826 * magnitudes[magnitudes.size() / 2]);
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (worst[i] > options.outlier_sigmas * robust_sigma) {
      (*inlier)[i] = false;
      left_out->push_back({seen[i]->name, "its plane is " + core::Fixed(worst[i] / robust_sigma, 0) +
                                              " robust sigmas off its mount's fit"});
    }
  }
}

// Adds the inlier planes' squared distances (mm) and normal components
// (radians) to the running sums; returns how many planes that is.
int AddInlierResidualSquares(const std::vector<PlaneResidual>& residuals, const std::vector<bool>& inlier,
                             const MountUnknowns& u, double* position_sq, double* normal_sq) {
  int used = 0;
  for (std::size_t i = 0; i < residuals.size(); ++i) {
    if (!inlier[i]) continue;
    ++used;
    const std::array<double, 3> e = EvaluatePlaneResidual(residuals[i], u);
    *position_sq += std::pow(e[0] * residuals[i].position_sigma, 2);
    *normal_sq += std::pow(e[1] * residuals[i].normal_sigma, 2) + std::pow(e[2] * residuals[i].normal_sigma, 2);
  }
  return used;
}

// A mount's sigmas: its tilt axis, its source and its normal at tilt 0.
struct MountSigmas {
  Eigen::Vector3d axis, source, normal;
};

// Sigmas: (J^T J)^-1 scaled by the residuals' variance. None where the fit
// has no uncertainty, with why in `too_uncertain` unless a mount before
// gave one.
std::optional<MountSigmas> MountCovarianceSigmas(const MountFrame& frame, const MountUnknowns& u, int used,
                                                 const ceres::Solver::Summary& summary, ceres::Problem* problem,
                                                 const std::string& id, std::string* too_uncertain) {
  const int dof = 3 * used - 5;
  if (dof <= 0) {
    if (too_uncertain->empty())
      *too_uncertain = "laser mount " + core::Quoted(id) + ": as many unknowns as measurements";
    return std::nullopt;
  }
  const double variance = 2.0 * summary.final_cost / dof;
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.min_reciprocal_condition_number = 1e-20;
  ceres::Covariance covariance(covariance_options);
  const std::vector<std::pair<const double*, const double*>> blocks = {{u.axis.data(), u.axis.data()},
                                                                       {u.offset.data(), u.offset.data()},
                                                                       {u.phi.data(), u.phi.data()},
                                                                       {u.axis.data(), u.phi.data()}};
  if (!covariance.Compute(blocks, problem)) {
    if (too_uncertain->empty()) {
      *too_uncertain = "laser mount " + core::Quoted(id) + ": its fit is singular, no uncertainty";
    }
    return std::nullopt;
  }
  Eigen::Matrix<double, 3, 3, Eigen::RowMajor> ca;
  Eigen::Matrix2d co;
  Eigen::Matrix<double, 1, 1> cp;
  Eigen::Matrix<double, 3, 1> cap;
  covariance.GetCovarianceBlock(u.axis.data(), u.axis.data(), ca.data());
  covariance.GetCovarianceBlock(u.offset.data(), u.offset.data(), co.data());
  covariance.GetCovarianceBlock(u.phi.data(), u.phi.data(), cp.data());
  covariance.GetCovarianceBlock(u.axis.data(), u.phi.data(), cap.data());
  Eigen::Matrix<double, 3, 2> basis;
  basis << frame.b1, frame.b2;
  MountSigmas sigmas;
  sigmas.axis = (variance * ca.diagonal()).cwiseSqrt();
  sigmas.source = (variance * (basis * co * basis.transpose()).diagonal()).cwiseSqrt();
  // The normal at tilt 0 through its first-order change with the axis and
  // phi (central differences).
  Eigen::Matrix4d c = Eigen::Matrix4d::Zero();
  c.topLeftCorner<3, 3>() = ca;
  c.topRightCorner<3, 1>() = cap;
  c.bottomLeftCorner<1, 3>() = cap.transpose();
  c(3, 3) = cp(0, 0);
  Eigen::Matrix<double, 3, 4> jacobian;
  const double h = 1e-7;
  for (int k = 0; k < 4; ++k) {
    MountUnknowns plus = u, minus = u;
    (k < 3 ? plus.axis[k] : plus.phi[0]) += h;
    (k < 3 ? minus.axis[k] : minus.phi[0]) -= h;
    formats::LaserMountCalibration a, b;
    SetMount(frame, plus, &a);
    SetMount(frame, minus, &b);
    jacobian.col(k) = (a.plane_normal_at_zero_tilt - b.plane_normal_at_zero_tilt) / (2 * h);
  }
  sigmas.normal = (variance * (jacobian * c * jacobian.transpose()).diagonal()).cwiseSqrt();
  return sigmas;
}

// The planes of one camera share its calibration's errors, which the
// covariance takes as independent: with three or more cameras, the spread
// of the fits each leaving one camera out (jackknife) is the sigma where it
// is larger.
void WidenMountSigmasByCameraJackknife(const std::vector<PlaneResidual>& residuals,
                                       const std::vector<const LaserPlaneObservation*>& seen,
                                       const std::vector<bool>& inlier, const MountFrame& frame, const MountUnknowns& u,
                                       const std::string& id, const formats::LaserMountCalibration& out,
                                       MountSigmas* sigmas) {
  std::set<int> cameras;
  for (std::size_t i = 0; i < seen.size(); ++i) {
    if (inlier[i]) cameras.insert(seen[i]->camera);
  }
  std::vector<formats::LaserMountCalibration> leave_one_out;
  for (int camera : cameras) {
    std::vector<bool> use = inlier;
    for (std::size_t i = 0; i < seen.size(); ++i) use[i] = use[i] && seen[i]->camera != camera;
    if (CountTilts(seen, use) < 2) continue;
    MountUnknowns v = u;
    ceres::Solver::Summary unused;
    Fit(residuals, use, 0.0, id, &v, &unused);
    formats::LaserMountCalibration fit = out;
    SetMount(frame, v, &fit);
    leave_one_out.push_back(fit);
  }
  if (leave_one_out.size() >= 3) {
    const double n = static_cast<double>(leave_one_out.size());
    const auto jackknife = [&](auto member) {
      Eigen::Vector3d mean = Eigen::Vector3d::Zero(), sq = Eigen::Vector3d::Zero();
      for (const auto& f : leave_one_out) mean += member(f) / n;
      for (const auto& f : leave_one_out) sq += (member(f) - mean).cwiseAbs2();
      return Eigen::Vector3d(((n - 1) / n * sq).cwiseSqrt());
    };
    sigmas->axis = sigmas->axis.cwiseMax(jackknife([](const auto& f) { return f.tilt_axis; }));
    sigmas->normal = sigmas->normal.cwiseMax(jackknife([](const auto& f) { return f.plane_normal_at_zero_tilt; }));
    // Across the axis only: the source's place along it is not observed.
    const Eigen::Vector3d d = out.tilt_axis;
    sigmas->source = sigmas->source.cwiseMax(jackknife([&](const auto& f) {
      const Eigen::Vector3d s = f.source_mm - out.source_mm;
      return Eigen::Vector3d(s - s.dot(d) * d);
    }));
  }
}

// Mount `m` fitted to its planes `seen` into result->mounts[m], with its
// sigmas; its residuals are added to the running sums.
void CalibrateOneLaserMount(const formats::Calibration& geometry, std::size_t m,
                            const std::vector<const LaserPlaneObservation*>& seen, const LaserMountOptions& options,
                            LaserMountResult* result, double* position_sq, double* normal_sq) {
  const formats::LaserMountCalibration& nominal = geometry.laser_mounts[m];
  const std::string& id = nominal.id;
  std::vector<bool> inlier(seen.size(), true);
  if (const std::size_t tilts = CountTilts(seen, inlier); tilts < 2) {
    throw core::Error("laser mount " + core::Quoted(id) + ": its stripe was measured at " + std::to_string(tilts) +
                      " tilt(s) on the plates; its tilt axis needs planes at two tilts or more");
  }
  const MountFrame frame = NominalMountFrame(nominal);
  const std::vector<PlaneResidual> residuals = MountPlaneResiduals(geometry, m, frame, seen);

  // Outliers left out after a robust solve; then least squares on the
  // inliers.
  const Eigen::Vector3d nominal_axis = nominal.tilt_axis.normalized();
  MountUnknowns u;
  u.axis = {nominal_axis.x(), nominal_axis.y(), nominal_axis.z()};
  ceres::Solver::Summary summary;
  LeaveOutOutlierPlanes(residuals, seen, id, options, &u, &summary, &inlier, &result->left_out);
  if (CountTilts(seen, inlier) < 2) {
    throw core::Error("laser mount " + core::Quoted(id) +
                      ": without its outlier planes, planes at one tilt are left; its tilt axis needs two");
  }
  const std::unique_ptr<ceres::Problem> problem = Fit(residuals, inlier, 0.0, id, &u, &summary);
  formats::LaserMountCalibration& out = result->mounts[m];
  SetMount(frame, u, &out);
  const int used = AddInlierResidualSquares(residuals, inlier, u, position_sq, normal_sq);
  result->planes_used += used;

  std::optional<MountSigmas> sigmas =
      MountCovarianceSigmas(frame, u, used, summary, problem.get(), id, &result->too_uncertain);
  if (!sigmas) return;
  WidenMountSigmasByCameraJackknife(residuals, seen, inlier, frame, u, id, out, &*sigmas);
  out.uncertainty.tilt_axis = sigmas->axis;
  out.uncertainty.source_mm = sigmas->source;
  out.uncertainty.plane_normal_at_zero_tilt = sigmas->normal;

  const double axis_deg = core::DegreesFromRadians(sigmas->axis.maxCoeff());
  if ((axis_deg > options.max_axis_sigma_deg || sigmas->source.maxCoeff() > options.max_source_sigma_mm) &&
      result->too_uncertain.empty()) {
    result->too_uncertain = "laser mount " + core::Quoted(id) + "'s tilt axis is uncertain to " +
                            core::Fixed(axis_deg, 3) + " degrees and " + core::Fixed(sigmas->source.maxCoeff(), 2) +
                            " mm (limits " + core::Fixed(options.max_axis_sigma_deg, 3) + " degrees, " +
                            core::Fixed(options.max_source_sigma_mm, 1) + " mm)";
  }
}

}  // namespace

LaserMountResult CalibrateLaserMounts(const formats::Calibration& geometry,
                                      const std::vector<LaserPlaneObservation>& planes,
                                      const LaserMountOptions& options) {
  core::ThrowIfInvalid(options.Check(), "laser mount calibration");
  LaserMountResult result;
  result.mounts = geometry.laser_mounts;
  std::map<int, std::vector<const LaserPlaneObservation*>> of_mount = LaserPlanesOfEachMount(geometry, planes);
  double position_sq = 0, normal_sq = 0;
  for (std::size_t m = 0; m < geometry.laser_mounts.size(); ++m) {
    CalibrateOneLaserMount(geometry, m, of_mount[static_cast<int>(m)], options, &result, &position_sq, &normal_sq);
  }
  if (result.planes_used > 0) {
    result.position_residual_rms_mm = std::sqrt(position_sq / result.planes_used);
    result.normal_residual_rms_deg = core::DegreesFromRadians(std::sqrt(normal_sq / (2.0 * result.planes_used)));
  }
  return result;
}

}  // namespace mesocap::calibration
