#include "calibration/light_arc_calibration.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <ceres/sphere_manifold.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>

#include "calibration/camera_rays.h"
#include "calibration/rig_frames.h"
#include "core/angles.h"

namespace mesocap::calibration {

core::CheckResult LightArcOptions::Check() const {
  if (!(sphere_radius_mm > 0 && sphere_radius_mm <= 1e4)) return "the mirror sphere's radius must be in (0, 10000] mm";
  if (!std::isfinite(sphere_centre_height_mm) || !std::isfinite(sphere_offset_mm)) {
    return "the mirror sphere's centre must be finite";
  }
  if (!(max_incidence_deg > 0 && max_incidence_deg < 90)) return "the maximum incidence must be in (0, 90) degrees";
  if (!(max_lamp_sigma_mm > 0)) return "the lamps' largest sigma must be positive";
  if (!(max_axis_sigma_deg > 0)) return "the arc axis' largest sigma must be positive";
  return {};
}

namespace {

// Where a lamp lies as seen in one highlight: on the mean reflected ray,
// origin and direction in the world.
struct MeanRay {
  Eigen::Vector3d origin, dir;
};

// The highlight's pixels back-projected, met with the sphere (centre, radius)
// and reflected; their directions averaged, each weighted by its signal and
// the solid angle its reflected rays span (from the rays through its
// edges). nullopt, with the reason in *problem, when a pixel's ray misses
// the sphere or meets it more obliquely than min_cos allows.
std::optional<MeanRay> MeanReflectedRay(const CameraRays& camera, const std::vector<HighlightPixel>& pixels,
                                        const Eigen::Vector3d& centre, double radius, double min_cos,
                                        std::string* problem) {
  const Eigen::Vector3d o = camera.centre();
  const auto reflect = [&](double u, double v, Eigen::Vector3d* point) -> std::optional<Eigen::Vector3d> {
    const Eigen::Vector3d d = camera.RayAt(u, v).normalized();
    // The ray meets the sphere at o + s d, s the nearer root of
    // s^2 + 2 s d.(o - c) + |o - c|^2 - R^2 = 0.
    const double b = d.dot(o - centre);
    const double disc = b * b - ((o - centre).squaredNorm() - radius * radius);
    if (disc <= 0) {
      *problem = "a pixel of the highlight looks past the sphere";
      return std::nullopt;
    }
    *point = o + (-b - std::sqrt(disc)) * d;
    const Eigen::Vector3d normal = (*point - centre) / radius;
    if (-d.dot(normal) < min_cos) {
      *problem = "seen at " + std::to_string(std::lround(core::DegreesFromRadians(std::acos(-d.dot(normal))))) +
                 " degrees from the sphere's normal, near its outline";
      return std::nullopt;
    }
    return (d - 2.0 * d.dot(normal) * normal).normalized();
  };
  if (pixels.empty()) {
    *problem = "no pixels";
    return std::nullopt;
  }
  Eigen::Vector3d dir_sum = Eigen::Vector3d::Zero(), origin_sum = Eigen::Vector3d::Zero();
  double weight_sum = 0.0;
  for (const HighlightPixel& px : pixels) {
    Eigen::Vector3d point, unused;
    const auto r = reflect(px.x, px.y, &point);
    const auto left = reflect(px.x - 0.5, px.y, &unused), right = reflect(px.x + 0.5, px.y, &unused);
    const auto up = reflect(px.x, px.y - 0.5, &unused), down = reflect(px.x, px.y + 0.5, &unused);
    if (!r || !left || !right || !up || !down) return std::nullopt;
    const double w = px.signal * (*right - *left).cross(*down - *up).norm();
    dir_sum += w * *r;
    origin_sum += w * point;
    weight_sum += w;
  }
  if (!(weight_sum > 0)) {
    *problem = "no signal";
    return std::nullopt;
  }
  return MeanRay{origin_sum / weight_sum, dir_sum.normalized()};
}

// A lamp lies on this ray: the mean reflected ray of one highlight, with its
// change per mm of the sphere's cup (sample frame) to first order, so the
// fit can move the sphere (its error, amplified about 2 D / R, would
// otherwise go straight into the lamps).
struct ReflectedRay {
  int lamp = 0;
  double arc_rad = 0.0;
  Eigen::Vector3d origin, dir;  // world, at cup0; dir unit
  Eigen::Matrix3d origin_per_cup, dir_per_cup;
  Eigen::Vector3d cup0;
  Eigen::Vector3d e1, e2;  // unit, perpendicular to dir and each other
};

// The angle (two components, radians, times `scale` mm) between a
// reflected ray and the direction from its origin to the lamp, the lamp at
// q + R(axis, arc) (p - q), q = q0 + s b1 + t b2. Angles, not distances:
// the highlight's error is an error of direction, and a distance would also
// be small at the sphere, where every ray of a lamp starts.
struct RayAngle {
  ReflectedRay ray;
  Eigen::Vector3d q0, b1, b2;
  double scale = 1.0;

  template <class T>
  bool operator()(const T* axis, const T* offset, const T* lamp, const T* cup, T* residual) const {
    T q[3], rel[3], angle_axis[3], turned[3], origin[3], dir[3];
    for (int i = 0; i < 3; ++i) {
      q[i] = T(q0[i]) + offset[0] * b1[i] + offset[1] * b2[i];
      rel[i] = lamp[i] - q[i];
      angle_axis[i] = axis[i] * ray.arc_rad;
      origin[i] = T(ray.origin[i]);
      dir[i] = T(ray.dir[i]);
      for (int k = 0; k < 3; ++k) {
        origin[i] += ray.origin_per_cup(i, k) * (cup[k] - ray.cup0[k]);
        dir[i] += ray.dir_per_cup(i, k) * (cup[k] - ray.cup0[k]);
      }
    }
    ceres::AngleAxisRotatePoint(angle_axis, rel, turned);
    T to_lamp[3], to_norm = T(0), dir_norm = T(0);
    for (int i = 0; i < 3; ++i) {
      to_lamp[i] = turned[i] + q[i] - origin[i];
      to_norm += to_lamp[i] * to_lamp[i];
      dir_norm += dir[i] * dir[i];
    }
    to_norm = ceres::sqrt(to_norm);
    dir_norm = ceres::sqrt(dir_norm);
    T along = T(0);
    for (int i = 0; i < 3; ++i) along += to_lamp[i] / to_norm * dir[i] / dir_norm;
    // The direction to the lamp less its part along the ray, on the ray's
    // two perpendiculars.
    T e1 = T(0), e2 = T(0);
    for (int i = 0; i < 3; ++i) {
      const T across = to_lamp[i] / to_norm - along * dir[i] / dir_norm;
      e1 += across * ray.e1[i];
      e2 += across * ray.e2[i];
    }
    residual[0] = scale * e1;
    residual[1] = scale * e2;
    return true;
  }
};

// Two unit vectors completing `d` to an orthonormal frame.
void Perpendiculars(const Eigen::Vector3d& d, Eigen::Vector3d* e1, Eigen::Vector3d* e2) {
  const Eigen::Vector3d seed = std::abs(d.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  *e1 = d.cross(seed).normalized();
  *e2 = d.cross(*e1);
}

struct UsableHighlight {
  const HighlightObservation* seen = nullptr;
  const CameraRays* camera = nullptr;
};

// The reflected ray of every usable highlight with the cup at `cup`, and
// its change per mm of the cup by central differences.
std::vector<ReflectedRay> ReflectedRays(const formats::Calibration& geometry,
                                        const std::vector<UsableHighlight>& usable, const Eigen::Vector3d& cup,
                                        double radius, double min_cos) {
  constexpr double kStepMm = 1e-3;
  std::vector<ReflectedRay> rays;
  for (const UsableHighlight& u : usable) {
    const core::RigidTransform sample = WorldFromSample(geometry.turntable, u.seen->turntable_rad);
    std::string problem;
    const auto ray_at = [&](const Eigen::Vector3d& c) {
      const std::optional<MeanRay> r =
          MeanReflectedRay(*u.camera, u.seen->pixels, sample.Apply(c), radius, min_cos, &problem);
      if (r) return *r;
      // A step of a micrometre took a pixel past the incidence limit: the
      // ray without the limit (the step changes it smoothly).
      const std::optional<MeanRay> unlimited =
          MeanReflectedRay(*u.camera, u.seen->pixels, sample.Apply(c), radius, 0.0, &problem);
      if (!unlimited) {
        throw core::Error(u.seen->name + ": the fitted sphere no longer meets the highlight's rays (" + problem +
                          "): the sphere's cup is far from its description");
      }
      return *unlimited;
    };
    ReflectedRay ray;
    ray.lamp = u.seen->lamp;
    ray.arc_rad = u.seen->arc_rad;
    ray.cup0 = cup;
    const MeanRay at = ray_at(cup);
    ray.origin = at.origin;
    ray.dir = at.dir;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d step = kStepMm * Eigen::Vector3d::Unit(k);
      const MeanRay plus = ray_at(cup + step), minus = ray_at(cup - step);
      ray.origin_per_cup.col(k) = (plus.origin - minus.origin) / (2 * kStepMm);
      ray.dir_per_cup.col(k) = (plus.dir - minus.dir) / (2 * kStepMm);
    }
    Perpendiculars(ray.dir, &ray.e1, &ray.e2);
    rays.push_back(ray);
  }
  return rays;
}

// The highlights whose pixels all meet the sphere where it is described,
// centred on `cup`; the others are reported in `left_out`. `rays_of` keeps
// the rays of the cameras the highlights point to; `ray_count` counts each
// lamp's highlights.
std::vector<UsableHighlight> FindUsableHighlights(const formats::Calibration& geometry,
                                                  const std::vector<HighlightObservation>& seen,
                                                  const Eigen::Vector3d& cup, double radius, double min_cos,
                                                  std::map<int, CameraRays>* rays_of, std::vector<int>* ray_count,
                                                  std::vector<LeftOutHighlight>* left_out) {
  std::vector<UsableHighlight> usable;
  for (const HighlightObservation& h : seen) {
    if (h.camera < 0 || h.camera >= static_cast<int>(geometry.cameras.size()) || h.lamp < 0 ||
        h.lamp >= static_cast<int>(geometry.lamps.size())) {
      throw core::Error(h.name + ": camera " + std::to_string(h.camera) + " or lamp " + std::to_string(h.lamp) +
                        " is not in the calibration");
    }
    auto it = rays_of->find(h.camera);
    if (it == rays_of->end()) it = rays_of->emplace(h.camera, CameraRays(geometry.cameras[h.camera])).first;
    std::string problem;
    const Eigen::Vector3d centre = WorldFromSample(geometry.turntable, h.turntable_rad).Apply(cup);
    if (!MeanReflectedRay(it->second, h.pixels, centre, radius, min_cos, &problem)) {
      left_out->push_back({h.name, problem});
      continue;
    }
    usable.push_back({&h, &it->second});
    ++(*ray_count)[h.lamp];
  }
  return usable;
}

// The fit's unknowns, and its problem, which points to them.
struct LightArcFit {
  std::vector<std::array<double, 3>> lamp;
  std::vector<double> distance;  // each lamp's nominal one: the scale of its ray angles
  Eigen::Vector3d b1, b2;        // across the nominal axis
  std::array<double, 2> offset = {0.0, 0.0};
  std::array<double, 3> axis;
  std::array<double, 3> cup;
  std::unique_ptr<ceres::Problem> problem;
  ceres::Solver::Summary summary;
  int tangent_parameters = 0;
};

// Start: each lamp at its nominal distance along its rays, turned back into
// the nominal arc's frame and averaged (their nearest point can lie back at
// the sphere, where they all start); the arc's axis nominal, the sphere's
// cup at `cup_start`.
void StartLightArcFit(const formats::Calibration& geometry, const std::vector<ReflectedRay>& rays,
                      const std::vector<int>& ray_count, const Eigen::Vector3d& cup_start, LightArcFit* fit) {
  const formats::LightArcCalibration& nominal = geometry.light_arc;
  fit->lamp.resize(geometry.lamps.size());
  fit->distance.assign(geometry.lamps.size(), 1.0);
  for (std::size_t l = 0; l < geometry.lamps.size(); ++l) {
    const std::string& id = geometry.lamps[l].id;
    if (ray_count[l] < 2) {
      throw core::Error("lamp " + core::Quoted(id) + ": " + std::to_string(ray_count[l]) +
                        " usable highlight(s) on the mirror sphere; its position needs two or more (cameras or "
                        "arc angles)");
    }
    fit->distance[l] = geometry.lamps[l].position_mm.norm();
    Eigen::Vector3d start = Eigen::Vector3d::Zero();
    for (const ReflectedRay& r : rays) {
      if (r.lamp == static_cast<int>(l))
        start += LightArcPointToWorld(nominal, -r.arc_rad, r.origin + fit->distance[l] * r.dir);
    }
    start /= ray_count[l];
    for (int i = 0; i < 3; ++i) fit->lamp[l][i] = start[i];
  }
  const Eigen::Vector3d nominal_dir = nominal.axis_direction.normalized();
  Perpendiculars(nominal_dir, &fit->b1, &fit->b2);
  fit->axis = {nominal_dir.x(), nominal_dir.y(), nominal_dir.z()};
  fit->cup = {cup_start.x(), cup_start.y(), cup_start.z()};
}

// The axis is observed when some lamp is seen at two arc angles.
void NoteWhetherArcAxisIsObserved(const std::vector<ReflectedRay>& rays, LightArcResult* result) {
  std::map<int, std::vector<double>> arcs_of_lamp;
  for (const ReflectedRay& r : rays) arcs_of_lamp[r.lamp].push_back(r.arc_rad);
  for (auto& [l, arcs] : arcs_of_lamp) {
    const auto [lo, hi] = std::minmax_element(arcs.begin(), arcs.end());
    if (*hi - *lo > 1e-6) result->axis_estimated = true;
  }
  if (!result->axis_estimated) {
    result->warnings.push_back(
        "the lamps were imaged at one light-arc angle only: the arc's axis is the nominal one, not estimated");
  }
}

// The lamps, the sphere's cup and, where observed, the arc's axis fitted to
// the rays' angles. Twice: the rays are first order in the cup's move, so
// they are recomputed where the first fit put the cup and the fit repeated.
void FitLightArcTwice(const formats::Calibration& geometry, const std::vector<UsableHighlight>& usable, double radius,
                      double min_cos, bool axis_estimated, std::vector<ReflectedRay>* rays, LightArcFit* fit) {
  const formats::LightArcCalibration& nominal = geometry.light_arc;
  for (int pass = 0; pass < 2; ++pass) {
    if (pass > 0) {
      *rays = ReflectedRays(geometry, usable, Eigen::Vector3d(fit->cup[0], fit->cup[1], fit->cup[2]), radius, min_cos);
    }
    fit->problem = std::make_unique<ceres::Problem>();
    for (const ReflectedRay& r : *rays) {
      fit->problem->AddResidualBlock(new ceres::AutoDiffCostFunction<RayAngle, 2, 3, 2, 3, 3>(new RayAngle{
                                         r, nominal.axis_point_mm, fit->b1, fit->b2, fit->distance[r.lamp]}),
                                     nullptr, fit->axis.data(), fit->offset.data(), fit->lamp[r.lamp].data(),
                                     fit->cup.data());
    }
    fit->problem->SetManifold(fit->axis.data(), new ceres::SphereManifold<3>());
    fit->tangent_parameters = 3 * static_cast<int>(geometry.lamps.size()) + 3;
    if (axis_estimated) {
      fit->tangent_parameters += 4;
    } else {
      fit->problem->SetParameterBlockConstant(fit->axis.data());
      fit->problem->SetParameterBlockConstant(fit->offset.data());
    }
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_QR;
    solver.max_num_iterations = 200;
    solver.function_tolerance = 1e-14;
    solver.parameter_tolerance = 1e-14;
    ceres::Solve(solver, fit->problem.get(), &fit->summary);
    if (!fit->summary.IsSolutionUsable()) throw core::Error("light arc: the fit failed: " + fit->summary.message);
  }
}

// The fitted lamps, sphere and (where estimated) arc into `result`, their
// sigmas not a number until the covariance gives them.
void SetLightArcEstimates(const formats::Calibration& geometry, const std::vector<ReflectedRay>& rays,
                          const LightArcFit& fit, int residuals, LightArcResult* result) {
  result->highlights_used = static_cast<int>(rays.size());
  result->ray_residual_rms_mm = std::sqrt(2.0 * fit.summary.final_cost / residuals);
  result->sphere_centre_mm = Eigen::Vector3d(fit.cup[0], fit.cup[1], fit.cup[2]);
  result->sphere_centre_sigma_mm = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const Eigen::Vector3d axis_dir(fit.axis[0], fit.axis[1], fit.axis[2]);
  const Eigen::Vector3d q = geometry.light_arc.axis_point_mm + fit.offset[0] * fit.b1 + fit.offset[1] * fit.b2;
  if (result->axis_estimated) {
    result->light_arc.axis_direction = axis_dir.normalized();
    result->light_arc.axis_point_mm = q;
  }
  for (std::size_t l = 0; l < geometry.lamps.size(); ++l) {
    result->lamp_ids.push_back(geometry.lamps[l].id);
    result->lamp_position.emplace_back(fit.lamp[l][0], fit.lamp[l][1], fit.lamp[l][2]);
    result->lamp_position_sigma.push_back(Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  }
}

// Sigmas: (J^T J)^-1 scaled by the residuals' variance. False, with why in
// result->too_uncertain, where the fit has no uncertainty.
bool SetLightArcSigmas(const LightArcFit& fit, int residuals, LightArcResult* result) {
  const int dof = residuals - fit.tangent_parameters;
  if (dof <= 0) {
    result->too_uncertain = "as many unknowns as ray angles: no uncertainty";
    return false;
  }
  const double variance = 2.0 * fit.summary.final_cost / dof;
  ceres::Covariance::Options covariance_options;
  covariance_options.algorithm_type = ceres::DENSE_SVD;
  covariance_options.min_reciprocal_condition_number = 1e-20;
  ceres::Covariance covariance(covariance_options);
  std::vector<std::pair<const double*, const double*>> blocks;
  for (const auto& p : fit.lamp) blocks.emplace_back(p.data(), p.data());
  if (result->axis_estimated) {
    blocks.emplace_back(fit.axis.data(), fit.axis.data());
    blocks.emplace_back(fit.offset.data(), fit.offset.data());
  }
  blocks.emplace_back(fit.cup.data(), fit.cup.data());
  if (!covariance.Compute(blocks, fit.problem.get())) {
    result->too_uncertain = "the lamps' and arc's parameters are not all observed (singular fit): no uncertainty";
    return false;
  }
  Eigen::Matrix3d cc;
  covariance.GetCovarianceBlock(fit.cup.data(), fit.cup.data(), cc.data());
  result->sphere_centre_sigma_mm = (variance * cc.diagonal()).cwiseSqrt();
  for (std::size_t l = 0; l < fit.lamp.size(); ++l) {
    Eigen::Matrix3d c;
    covariance.GetCovarianceBlock(fit.lamp[l].data(), fit.lamp[l].data(), c.data());
    result->lamp_position_sigma[l] = (variance * c.diagonal()).cwiseSqrt();
  }
  if (result->axis_estimated) {
    Eigen::Matrix3d ca;
    covariance.GetCovarianceBlock(fit.axis.data(), fit.axis.data(), ca.data());
    Eigen::Matrix2d co;
    covariance.GetCovarianceBlock(fit.offset.data(), fit.offset.data(), co.data());
    Eigen::Matrix<double, 3, 2> basis;
    basis << fit.b1, fit.b2;
    const Eigen::Matrix3d cq = basis * co * basis.transpose();
    result->light_arc.uncertainty.axis_direction = (variance * ca.diagonal()).cwiseSqrt();
    result->light_arc.uncertainty.axis_point_mm = (variance * cq.diagonal()).cwiseSqrt();
  }
  return true;
}

// Why the fit is too uncertain where a lamp's or the axis' sigma passes its
// limit (the first such).
void CheckLightArcSigmaLimits(const LightArcOptions& options, LightArcResult* result) {
  for (std::size_t l = 0; l < result->lamp_position_sigma.size(); ++l) {
    const double worst = result->lamp_position_sigma[l].maxCoeff();
    if (worst > options.max_lamp_sigma_mm && result->too_uncertain.empty()) {
      result->too_uncertain = "lamp " + core::Quoted(result->lamp_ids[l]) + "'s position is uncertain to " +
                              core::Fixed(worst, 1) + " mm (limit " + core::Fixed(options.max_lamp_sigma_mm, 1) +
                              " mm)";
    }
  }
  if (result->axis_estimated && result->too_uncertain.empty()) {
    const double direction_deg = core::DegreesFromRadians(result->light_arc.uncertainty.axis_direction->maxCoeff());
    const double point_mm = result->light_arc.uncertainty.axis_point_mm->maxCoeff();
    if (direction_deg > options.max_axis_sigma_deg || point_mm > options.max_lamp_sigma_mm) {
      result->too_uncertain = "the arc's axis is uncertain to " + core::Fixed(direction_deg, 3) + " degrees and " +
                              core::Fixed(point_mm, 1) + " mm (limits " + core::Fixed(options.max_axis_sigma_deg, 3) +
                              " degrees, " + core::Fixed(options.max_lamp_sigma_mm, 1) + " mm)";
    }
  }
}

}  // namespace

LightArcResult CalibrateLightArc(const formats::Calibration& geometry, const std::vector<HighlightObservation>& seen,
                                 const LightArcOptions& options) {
  core::ThrowIfInvalid(options.Check(), "light arc");
  const double radius = options.sphere_radius_mm;
  const double min_cos = std::cos(core::RadiansFromDegrees(options.max_incidence_deg));
  LightArcResult result;
  result.light_arc = geometry.light_arc;
  const Eigen::Vector3d cup_start(options.sphere_offset_mm, 0.0, options.sphere_centre_height_mm);

  std::map<int, CameraRays> rays_of;
  std::vector<int> ray_count(geometry.lamps.size(), 0);
  const std::vector<UsableHighlight> usable =
      FindUsableHighlights(geometry, seen, cup_start, radius, min_cos, &rays_of, &ray_count, &result.left_out);
  std::vector<ReflectedRay> rays = ReflectedRays(geometry, usable, cup_start, radius, min_cos);
  LightArcFit fit;
  StartLightArcFit(geometry, rays, ray_count, cup_start, &fit);
  NoteWhetherArcAxisIsObserved(rays, &result);
  FitLightArcTwice(geometry, usable, radius, min_cos, result.axis_estimated, &rays, &fit);
  const int residuals = 2 * static_cast<int>(rays.size());
  SetLightArcEstimates(geometry, rays, fit, residuals, &result);
  if (SetLightArcSigmas(fit, residuals, &result)) CheckLightArcSigmaLimits(options, &result);
  return result;
}

}  // namespace mesocap::calibration
