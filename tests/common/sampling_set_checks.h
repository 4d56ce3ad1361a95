// Checks that every sampling set must pass (order, weights, Nearest against
// brute force, Interpolate exact at the set's directions, valid and
// continuous blends, JSON round trip) and the helpers they share: run on
// core's sets in tests/core and on the Bonn database's sets in tests/bonn.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/json_field_reader.h"
#include "core/sampling_set.h"
#include "tests/common/error_of.h"

namespace mesocap::testing {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDeg = kPi / 180.0;

inline bool Contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

inline Eigen::Vector3d RandomDirection(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::Vector3d d;
  do {
    d = {normal(rng), normal(rng), normal(rng)};
  } while (d.norm() < 1e-6);
  return d.normalized();
}

// A direction with theta uniform in [lo, hi] and phi uniform in [0, 2 pi).
inline Eigen::Vector3d RandomDirectionIn(std::mt19937& rng, double lo, double hi) {
  std::uniform_real_distribution<double> theta(lo, hi);
  std::uniform_real_distribution<double> phi(0.0, 2 * kPi);
  return core::DirectionFromAngles(theta(rng), phi(rng));
}

// The blend of per-direction values f(i).
inline double Blended(const core::SamplingSet::Blend& b, const std::function<double(int)>& f) {
  double sum = 0.0;
  for (int k = 0; k < b.count; ++k) sum += b.weight[k] * f(b.index[k]);
  return sum;
}

// A smooth function on the sphere for continuity checks.
inline double Smooth(const Eigen::Vector3d& d) { return d.x() + 2 * d.y() + 3 * d.z() * d.z(); }

// Counts the members of each ring, in order, and checks each ring's azimuths.
inline void ExpectRings(const core::SamplingSet& set, const std::vector<double>& theta_deg,
                        const std::vector<int>& count, const std::vector<double>& offset_deg) {
  int i = 0;
  for (std::size_t r = 0; r < theta_deg.size(); ++r) {
    for (int k = 0; k < count[r]; ++k, ++i) {
      ASSERT_LT(i, set.size());
      EXPECT_NEAR(set.angles(i).theta, theta_deg[r] * kDeg, 1e-15) << set.name() << " " << i;
      EXPECT_NEAR(set.angles(i).phi, (offset_deg[r] + 360.0 * k / count[r]) * kDeg, 1e-14) << set.name() << " " << i;
    }
  }
  EXPECT_EQ(i, set.size());
}

inline void ExpectValidBlend(const core::SamplingSet& set, const core::SamplingSet::Blend& b) {
  ASSERT_GE(b.count, 1);
  ASSERT_LE(b.count, 4);
  double sum = 0.0;
  for (int k = 0; k < b.count; ++k) {
    ASSERT_GE(b.index[k], 0);
    ASSERT_LT(b.index[k], set.size());
    EXPECT_GT(b.weight[k], 0.0);
    sum += b.weight[k];
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);
}

// Named sets list their directions ring by ring from the pole, then by phi.
inline void ExpectOrderedRingByRingThenByPhi(const core::SamplingSet& set) {
  const std::string& name = set.name();
  for (int i = 0; i < set.size(); ++i) {
    EXPECT_GE(set.angles(i).phi, 0.0) << name;
    EXPECT_LT(set.angles(i).phi, 2 * kPi) << name;
    EXPECT_LT(set.angles(i).theta, kPi / 2) << name;
    if (i == 0) continue;
    const auto& prev = set.angles(i - 1);
    const auto& cur = set.angles(i);
    EXPECT_TRUE(prev.theta < cur.theta || (prev.theta == cur.theta && prev.phi < cur.phi)) << name << " at " << i;
  }
}

inline void ExpectWeightsSumToTwoPi(const core::SamplingSet& set) {
  double sum = 0.0;
  for (int i = 0; i < set.size(); ++i) {
    EXPECT_GT(set.weight(i), 0.0);
    sum += set.weight(i);
  }
  EXPECT_NEAR(sum, 2 * kPi, 1e-12) << set.name();
}

inline void ExpectNearestMatchesBruteForce(const core::SamplingSet& set, std::mt19937& rng) {
  for (int t = 0; t < 5000; ++t) {
    // The whole sphere: below the horizon too.
    const Eigen::Vector3d d = t % 2 ? RandomDirection(rng) : RandomDirectionIn(rng, 0, kPi / 2);
    double best = -2.0;
    for (int i = 0; i < set.size(); ++i) best = std::max(best, set.direction(i).dot(d));
    const int found = set.Nearest(d);
    ASSERT_GE(found, 0);
    ASSERT_LT(found, set.size());
    ASSERT_NEAR(set.direction(found).dot(d), best, 1e-12) << set.name() << " at trial " << t;
  }
  for (int i = 0; i < set.size(); ++i) EXPECT_EQ(set.Nearest(set.direction(i)), i) << set.name();
}

inline void ExpectInterpolateExactAtSetDirections(const core::SamplingSet& set) {
  for (int i = 0; i < set.size(); ++i) {
    const auto b = set.Interpolate(set.direction(i));
    ASSERT_EQ(b.count, 1) << set.name() << " " << i;
    EXPECT_EQ(b.index[0], i) << set.name();
    EXPECT_EQ(b.weight[0], 1.0) << set.name();
  }
}

inline void ExpectBlendsValid(const core::SamplingSet& set, std::mt19937& rng) {
  for (int t = 0; t < 2000; ++t) ExpectValidBlend(set, set.Interpolate(RandomDirection(rng)));
}

inline void ExpectInterpolateContinuous(const core::SamplingSet& set, std::mt19937& rng) {
  std::normal_distribution<double> normal;
  const auto value = [&](int i) { return Smooth(set.direction(i)); };
  for (int t = 0; t < 2000; ++t) {
    // Away from the pole, where a set without a pole sample jumps with phi.
    const Eigen::Vector3d d = RandomDirectionIn(rng, 0.01, kPi / 2);
    const Eigen::Vector3d step(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d moved = (d + 1e-7 * step.normalized()).normalized();
    // |Smooth| < 6 and the weights move at most ~1/(sin theta * ring gap) per
    // radian, about 1e3 here: a change over 1e-3 would be a jump.
    ASSERT_NEAR(Blended(set.Interpolate(moved), value), Blended(set.Interpolate(d), value), 1e-3) << set.name();
  }
}

// Inside the bracketing rings and away from the phi = 0 seam, a + b theta +
// c phi is blended exactly (the ranges in degrees).
inline void ExpectLinearInThetaAndPhiReproduced(const core::SamplingSet& set, double theta_lo, double theta_hi,
                                                double phi_lo, double phi_hi, std::mt19937& rng) {
  const auto linear = [](double theta, double phi) { return 0.5 + 2.0 * theta - 0.3 * phi; };
  std::uniform_real_distribution<double> theta(theta_lo * kDeg, theta_hi * kDeg);
  std::uniform_real_distribution<double> phi(phi_lo * kDeg, phi_hi * kDeg);
  for (int t = 0; t < 2000; ++t) {
    const double th = theta(rng);
    const double ph = phi(rng);
    const double got = Blended(set.Interpolate(core::DirectionFromAngles(th, ph)),
                               [&](int i) { return linear(set.angles(i).theta, set.angles(i).phi); });
    ASSERT_NEAR(got, linear(th, ph), 1e-12) << set.name() << " at " << th << ", " << ph;
  }
}

inline void ExpectJsonRoundTrip(const core::SamplingSet& set) {
  using nlohmann::json;
  const json doc = json::parse(json{{"view_directions", ToJson(set)}}.dump());
  const core::JsonFieldReader root(doc, "material.json");
  const core::SamplingSet back = core::ReadSamplingSet(root.Object("view_directions"));
  EXPECT_EQ(back.name(), set.name());
  ASSERT_EQ(back.size(), set.size());
  for (int i = 0; i < set.size(); ++i) {
    EXPECT_NEAR(back.angles(i).theta, set.angles(i).theta, 1e-9) << set.name() << " " << i;
    EXPECT_NEAR(back.angles(i).phi, set.angles(i).phi, 1e-9) << set.name() << " " << i;
    EXPECT_NEAR(back.weight(i), set.weight(i), 1e-12) << set.name() << " " << i;
  }
}

}  // namespace mesocap::testing
