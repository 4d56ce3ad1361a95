// Rays for the scene tests: directions given as (theta, phi) in degrees, as
// the paper gives them, and the distance to a scene's first hit.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <random>

#include "core/angles.h"
#include "sim/mesostructure_scene.h"

namespace mesocap::sim::scene_rays {

using Vec = Eigen::Vector3d;

inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDeg = core::kRadiansPerDegree;

// The unit direction (theta, phi) in degrees, pointing away from the surface.
inline Vec Omega(double theta_deg, double phi_deg) {
  const double t = theta_deg * kDeg, p = phi_deg * kDeg;
  return {std::sin(t) * std::cos(p), std::sin(t) * std::sin(p), std::cos(t)};
}

inline Vec RandomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  Vec v;
  do v = Vec(normal(rng), normal(rng), normal(rng));
  while (v.norm() < 1e-6);
  return v.normalized();
}

inline double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

inline std::optional<double> Distance(const MesostructureScene& scene, const Vec& origin, const Vec& dir,
                                      double t_min = 0.0, double t_max = kInf) {
  const auto hit = scene.Intersect(origin, dir, t_min, t_max);
  if (!hit) return std::nullopt;
  return hit->distance;
}

}  // namespace mesocap::sim::scene_rays
