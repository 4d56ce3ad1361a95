#include "core/sampling_set.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <numbers>
#include <random>

#include "core/angles.h"
#include "core/error.h"
#include "tests/common/sampling_set_checks.h"

namespace mesocap::core {
namespace {

using nlohmann::json;

using testing::Blended;
using testing::Contains;
using testing::ErrorOf;
using testing::kDeg;
using testing::kPi;
using testing::RandomDirection;
using testing::RandomDirectionIn;

// Core's named sets; the Bonn database's (ubo2003, ubo2014) are checked in
// tests/bonn/ubo_sampling_sets_test.cc.
const std::vector<std::string> kNamedSets = {"paper12x5", "paper12x8", "grid24x6", "grid1x1", "grid7x3"};

// ---------------------------------------------------------------- angles

TEST(Angles, RoundTripAndConventions) {
  std::mt19937 rng(1);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d d = RandomDirection(rng);
    const SphericalAngles a = AnglesFromDirection(3.5 * d);  // any length
    EXPECT_GE(a.theta, 0.0);
    EXPECT_LE(a.theta, kPi);
    EXPECT_GE(a.phi, 0.0);
    EXPECT_LT(a.phi, 2 * kPi);
    EXPECT_LT((DirectionFromAngles(a.theta, a.phi) - d).norm(), 1e-14);
  }
  // +z is theta 0; phi runs from +X towards +Y.
  const SphericalAngles y = AnglesFromDirection({0, 1, 0});
  EXPECT_NEAR(y.theta, kPi / 2, 1e-15);
  EXPECT_NEAR(y.phi, kPi / 2, 1e-15);
  EXPECT_NEAR(AnglesFromDirection({0, -1, 1}).phi, 1.5 * kPi, 1e-15);
  EXPECT_NEAR(DirectionFromAngles(0.0, 1.0).z(), 1.0, 1e-15);
}

TEST(Angles, PoleHasPhiZeroAndSmallThetaIsAccurate) {
  EXPECT_EQ(AnglesFromDirection({0, 0, 2}).phi, 0.0);
  EXPECT_EQ(AnglesFromDirection({0, 0, 2}).theta, 0.0);
  EXPECT_EQ(AnglesFromDirection({1e-14, -1e-14, 1}).phi, 0.0);
  EXPECT_NEAR(AnglesFromDirection({0, 0, -1}).theta, kPi, 1e-15);
  // acos(z) would give 0 here; the polar angle is 1e-9 to full precision.
  EXPECT_NEAR(AnglesFromDirection({1e-9, 0, 1}).theta, 1e-9, 1e-22);
  // Just below phi = 2 pi wraps into [0, 2 pi).
  EXPECT_LT(AnglesFromDirection({1, -1e-300, 0}).phi, 2 * kPi);
}

TEST(Angles, RejectsZeroAndNonFinite) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(Contains(ErrorOf([] { AnglesFromDirection({0, 0, 0}); }), "zero"));
  EXPECT_TRUE(Contains(ErrorOf([&] { AnglesFromDirection({nan, 0, 1}); }), "finite"));
  EXPECT_TRUE(Contains(ErrorOf([&] { AnglesFromDirection({0, inf, 1}); }), "finite"));
  EXPECT_TRUE(Contains(ErrorOf([&] { DirectionFromAngles(nan, 0); }), "finite"));
}

// ---------------------------------------------------------------- named sets

TEST(SamplingSetNamed, SizesAndNames) {
  const std::vector<std::pair<std::string, int>> sizes = {
      {"paper12x5", 60}, {"paper12x8", 96}, {"grid24x6", 144}, {"grid1x1", 1}, {"grid7x3", 21}};
  for (const auto& [name, size] : sizes) {
    const SamplingSet set = SamplingSet::Named(name);
    EXPECT_EQ(set.name(), name);
    EXPECT_EQ(set.size(), size) << name;
  }
  EXPECT_EQ(SamplingSet::RegularGrid(24, 6).name(), "grid24x6");
}

TEST(SamplingSetNamed, OrderedRingByRingThenByPhi) {
  for (const auto& name : kNamedSets) testing::ExpectOrderedRingByRingThenByPhi(SamplingSet::Named(name));
}

TEST(SamplingSetNamed, RegularGridAngles) {
  const SamplingSet set = SamplingSet::RegularGrid(24, 6);
  for (int j = 0; j < 6; ++j) {
    for (int k = 0; k < 24; ++k) {
      const auto& a = set.angles(j * 24 + k);
      EXPECT_NEAR(a.theta, (j + 0.5) * 15 * kDeg, 1e-15);
      EXPECT_NEAR(a.phi, k * 15 * kDeg, 1e-14);
    }
  }
}

TEST(SamplingSetNamed, PaperSetsArePlacedAsRegularGrids) {
  for (const auto& [name, polar] : std::vector<std::pair<std::string, int>>{{"paper12x5", 5}, {"paper12x8", 8}}) {
    const SamplingSet paper = SamplingSet::Named(name);
    const SamplingSet grid = SamplingSet::RegularGrid(12, polar);
    ASSERT_EQ(paper.size(), grid.size());
    for (int i = 0; i < paper.size(); ++i) {
      EXPECT_EQ(paper.angles(i).theta, grid.angles(i).theta);
      EXPECT_EQ(paper.angles(i).phi, grid.angles(i).phi);
    }
  }
}

TEST(SamplingSetNamed, RejectsUnknownNamesAndBadGrids) {
  // The Bonn database's names are not core's (bonn::NamedSamplingSet knows them).
  for (const std::string bad : {"ubo2003", "ubo2015", "", "grid", "grid24", "grid24x", "gridx6", "grid024x6",
                                "grid+2x6", "grid2x6 ", "grid99999999999x1"}) {
    const std::string msg = ErrorOf([&] { SamplingSet::Named(bad); });
    EXPECT_TRUE(Contains(msg, "paper12x8") && Contains(msg, "grid<A>x<P>")) << bad << ": " << msg;
    EXPECT_FALSE(SamplingSet::FindNamed(bad).has_value()) << bad;
  }
  EXPECT_TRUE(Contains(ErrorOf([] { SamplingSet::Named("grid0x6"); }), "at least 1"));
  EXPECT_TRUE(Contains(ErrorOf([] { SamplingSet::RegularGrid(24, 0); }), "at least 1"));
  EXPECT_TRUE(Contains(ErrorOf([] { SamplingSet::RegularGrid(100, 1001); }), "100000"));
  EXPECT_TRUE(Contains(ErrorOf([] { SamplingSet::RegularGrid(1 << 30, 1 << 30); }), "100000"));
  EXPECT_EQ(SamplingSet::RegularGrid(100, 1000).size(), 100000);
}

// ---------------------------------------------------------------- weights

TEST(SamplingSetWeights, SumToTwoPi) {
  for (const auto& name : kNamedSets) testing::ExpectWeightsSumToTwoPi(SamplingSet::Named(name));
}

TEST(SamplingSetWeights, RegularGridGivesBandSolidAngles) {
  const SamplingSet set = SamplingSet::RegularGrid(24, 6);
  for (int j = 0; j < 6; ++j) {
    const double band = 2 * kPi * (std::cos(j * 15 * kDeg) - std::cos((j + 1) * 15 * kDeg));
    for (int k = 0; k < 24; ++k) EXPECT_NEAR(set.weight(j * 24 + k), band / 24, 1e-15);
  }
}

// ---------------------------------------------------------------- FromAngles

TEST(SamplingSetFromAngles, KeepsOrderAndGroupsRings) {
  // Rings out of order, and a theta 5e-10 off its ring.
  const SamplingSet set =
      SamplingSet::FromAngles("mine", {{0.5, 1.0}, {0.2, 0.0}, {0.5 + 5e-10, 3.0}, {0.0, 2.0}, {0.5, -1.0}});
  EXPECT_EQ(set.name(), "mine");
  ASSERT_EQ(set.size(), 5);
  EXPECT_EQ(set.angles(0).theta, 0.5);
  EXPECT_EQ(set.angles(1).theta, 0.2);
  EXPECT_EQ(set.angles(2).theta, 0.5);                   // joined the ring at 0.5
  EXPECT_EQ(set.angles(3).phi, 0.0);                     // pole
  EXPECT_NEAR(set.angles(4).phi, 2 * kPi - 1.0, 1e-15);  // wrapped
  // Three rings: bands [0, 0.1], [0.1, 0.35], [0.35, pi/2].
  EXPECT_NEAR(set.weight(3), 2 * kPi * (1 - std::cos(0.1)), 1e-15);
  EXPECT_NEAR(set.weight(1), 2 * kPi * (std::cos(0.1) - std::cos(0.35)), 1e-15);
  EXPECT_NEAR(set.weight(0), 2 * kPi * std::cos(0.35) / 3, 1e-15);
}

TEST(SamplingSetFromAngles, RejectsBadAnglesNamingTheIndex) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const double theta : {-0.1, kPi / 2, 2.0, nan}) {
    const std::string msg = ErrorOf([&] { SamplingSet::FromAngles("s", {{0.1, 0}, {0.2, 0}, {theta, 0}}); });
    EXPECT_TRUE(Contains(msg, "direction 2")) << msg;
  }
  EXPECT_TRUE(Contains(ErrorOf([&] { SamplingSet::FromAngles("s", {{0.1, nan}}); }), "direction 0"));
  EXPECT_TRUE(Contains(ErrorOf([] { SamplingSet::FromAngles("s", {}); }), "no directions"));
}

TEST(SamplingSetFromAngles, RejectsDuplicates) {
  const std::string msg = ErrorOf([] { SamplingSet::FromAngles("s", {{0.3, 1.0}, {0.4, 1.0}, {0.3, 1.0 + 2 * kPi}}); });
  EXPECT_TRUE(Contains(msg, "directions 0 and 2 coincide")) << msg;
  // Across phi = 0, and at the pole where phi does not matter.
  EXPECT_TRUE(Contains(ErrorOf([] { SamplingSet::FromAngles("s", {{0.3, 1e-12}, {0.3, -1e-12}}); }), "coincide"));
  EXPECT_TRUE(Contains(ErrorOf([] { SamplingSet::FromAngles("s", {{0.0, 0.0}, {0.0, 1.0}}); }), "coincide"));
  EXPECT_NO_THROW(SamplingSet::FromAngles("s", {{0.3, 0.0}, {0.3, 1e-8}}));
}

// ---------------------------------------------------------------- Nearest

// Sets to check search code against: every named set, plus irregular rings
// (one member off the pole, two-member rings, no pole sample).
std::vector<SamplingSet> AllTestSets() {
  std::vector<SamplingSet> sets;
  for (const auto& name : kNamedSets) sets.push_back(SamplingSet::Named(name));
  sets.push_back(SamplingSet::FromAngles(
      "irregular", {{0.3, 2.0}, {0.7, 0.1}, {0.7, 3.0}, {0.71, 5.0}, {1.4, 1.0}, {1.4, 1.1}, {1.4, 4.0}, {1.5, 0.5}}));
  return sets;
}

TEST(SamplingSetNearest, MatchesBruteForce) {
  std::mt19937 rng(7);
  for (const SamplingSet& set : AllTestSets()) testing::ExpectNearestMatchesBruteForce(set, rng);
}

TEST(SamplingSetNearest, PoleAndZero) {
  const SamplingSet grid = SamplingSet::RegularGrid(24, 6);
  const int at_pole = grid.Nearest({0, 0, 1});
  EXPECT_LT(at_pole, 24);  // first ring; every member is equally near
  EXPECT_THROW(grid.Nearest({0, 0, 0}), Error);
}

// ---------------------------------------------------------------- Interpolate

TEST(SamplingSetInterpolate, ExactAtSetDirections) {
  for (const SamplingSet& set : AllTestSets()) testing::ExpectInterpolateExactAtSetDirections(set);
}

TEST(SamplingSetInterpolate, WeightsNonNegativeSumToOne) {
  std::mt19937 rng(3);
  for (const SamplingSet& set : AllTestSets()) testing::ExpectBlendsValid(set, rng);
}

TEST(SamplingSetInterpolate, ReproducesFunctionsLinearInThetaAndPhi) {
  std::mt19937 rng(5);
  testing::ExpectLinearInThetaAndPhiReproduced(SamplingSet::Named("grid24x6"), 7.5, 82.5, 0, 345, rng);
}

TEST(SamplingSetInterpolate, Continuous) {
  std::mt19937 rng(11);
  for (const SamplingSet& set : AllTestSets()) testing::ExpectInterpolateContinuous(set, rng);
}

TEST(SamplingSetInterpolate, CosThetaOnRegularGridWithinBound) {
  // P = 6 bands of h = 15 degrees. Between rings (and above the first, where
  // the clamp costs 1 - cos(h/2)) linear interpolation of cos errs at most
  // h^2/8; beyond the last ring the clamp errs at most sin(h/2).
  const SamplingSet set = SamplingSet::RegularGrid(24, 6);
  const double h = 15 * kDeg;
  const auto cos_theta = [&](int i) { return std::cos(set.angles(i).theta); };
  std::mt19937 rng(13);
  double worst_inside = 0.0;
  double worst_grazing = 0.0;
  for (int t = 0; t < 5000; ++t) {
    const Eigen::Vector3d d = RandomDirectionIn(rng, 0, kPi / 2);
    const double err = std::abs(Blended(set.Interpolate(d), cos_theta) - d.z());
    double& worst = AnglesFromDirection(d).theta <= 82.5 * kDeg ? worst_inside : worst_grazing;
    worst = std::max(worst, err);
  }
  EXPECT_LE(worst_inside, h * h / 8 + 1e-12);
  EXPECT_GT(worst_inside, 0.5 * h * h / 8);  // the bound is not vacuous
  EXPECT_LE(worst_grazing, std::sin(h / 2) + 1e-12);
}

TEST(SamplingSetInterpolate, NearThePoleWithoutAPoleSample) {
  // Above the first ring (7.5 degrees) the blend is the first ring at d's phi.
  const SamplingSet set = SamplingSet::RegularGrid(24, 6);
  const double step = 15 * kDeg;
  for (const double theta : {1e-8, 3 * kDeg, 7.4 * kDeg}) {
    const auto b = set.Interpolate(DirectionFromAngles(theta, 0.4 * step));
    ASSERT_EQ(b.count, 2);
    EXPECT_EQ(b.index[0], 0);
    EXPECT_EQ(b.index[1], 1);
    EXPECT_NEAR(b.weight[1], 0.4, 1e-9);
    // Across phi = 0: between the last member of the ring and the first.
    const auto seam = set.Interpolate(DirectionFromAngles(theta, -0.25 * step));
    ASSERT_EQ(seam.count, 2);
    EXPECT_EQ(seam.index[0], 23);
    EXPECT_EQ(seam.index[1], 0);
    EXPECT_NEAR(seam.weight[1], 0.75, 1e-9);
  }
  // At the pole itself phi is 0 by convention: the first member alone.
  const auto at_pole = set.Interpolate({0, 0, 1});
  ASSERT_EQ(at_pole.count, 1);
  EXPECT_EQ(at_pole.index[0], 0);
}

TEST(SamplingSetInterpolate, AtGrazingClampsToTheLastRing) {
  // grid24x6's last ring is at 82.5 degrees, members 120..143.
  const SamplingSet set = SamplingSet::RegularGrid(24, 6);
  const double phi = (2 + 0.3) * 15 * kDeg;
  for (const double theta_deg : {82.6, 89.999, 90.0, 120.0}) {
    const auto b = set.Interpolate(DirectionFromAngles(theta_deg * kDeg, phi));
    ASSERT_EQ(b.count, 2) << theta_deg;
    EXPECT_EQ(b.index[0], 122);
    EXPECT_EQ(b.index[1], 123);
    EXPECT_NEAR(b.weight[1], 0.3, 1e-9);
  }
  // On the last ring itself, between members.
  const auto on_ring = set.Interpolate(DirectionFromAngles(82.5 * kDeg, phi));
  ASSERT_EQ(on_ring.count, 2);
  EXPECT_EQ(on_ring.index[0], 122);
}

// ---------------------------------------------------------------- JSON

TEST(SamplingSetJson, RoundTripsEveryNamedSet) {
  for (const SamplingSet& set : AllTestSets()) testing::ExpectJsonRoundTrip(set);
}

// The FormatError message for reading `directions` as "view_directions".
std::string ReadError(const json& directions, const json& name = "s") {
  const json doc = {{"view_directions", {{"name", name}, {"directions_deg", directions}}}};
  const JsonFieldReader root(doc, "material.json");
  return ErrorOf<FormatError>([&] { ReadSamplingSet(root.Object("view_directions")); });
}

TEST(SamplingSetJson, RejectsBadEntriesNamingTheField) {
  const json good = {10, 0};
  const auto with = [&](const json& bad) { return json::array({good, json{20, 0}, json{30, 0}, bad}); };
  for (const json& bad : {json{95, 0}, json{-1, 0}, json{90, 0}, json{10}, json{10, 20, 30}, json{"10", 0}, json(10),
                          json{10, nullptr}, json{10, std::numeric_limits<double>::quiet_NaN()}}) {
    const std::string msg = ReadError(with(bad));
    EXPECT_TRUE(Contains(msg, "material.json")) << msg;
    EXPECT_TRUE(Contains(msg, "view_directions.directions_deg[3]")) << msg;
  }
  EXPECT_TRUE(Contains(ReadError(with(json{95, 0})), "[0, 90)"));
}

TEST(SamplingSetJson, RejectsBadListsAndNames) {
  EXPECT_TRUE(Contains(ReadError(json::array()), "view_directions.directions_deg"));
  EXPECT_TRUE(Contains(ReadError(json::array()), "1 to 100000"));
  EXPECT_TRUE(Contains(ReadError(json{{"a", 1}}), "list"));
  json many = json::array();
  for (int i = 0; i <= 100000; ++i) many.push_back(json{45.0, i * 360.0 / 100001});
  EXPECT_TRUE(Contains(ReadError(many), "got 100001"));
  const std::string dup = ReadError(json{json{10, 0}, json{10, 360}});
  EXPECT_TRUE(Contains(dup, "view_directions.directions_deg")) << dup;
  EXPECT_TRUE(Contains(dup, "directions 0 and 1 coincide")) << dup;
  EXPECT_TRUE(Contains(ReadError(json{json{10, 0}}, 5), "view_directions.name"));
}

}  // namespace
}  // namespace mesocap::core
