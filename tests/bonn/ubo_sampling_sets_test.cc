// The Bonn database's sampling sets (UBO2003, UBO2014 dome 1): their rings
// as the database gives them, the checks every sampling set passes
// (tests/common/sampling_set_checks.h), and the lookup by name that knows
// them besides core's sets.
#include "interop/bonn/ubo_sampling_sets.h"

#include <gtest/gtest.h>

#include <random>

#include "core/error.h"
#include "tests/common/sampling_set_checks.h"

namespace mesocap::bonn {
namespace {

using core::DirectionFromAngles;
using core::SamplingSet;
using testing::Blended;
using testing::Contains;
using testing::ErrorOf;

TEST(UboSamplingSets, SizesAndNames) {
  for (const auto& [name, size] : std::vector<std::pair<std::string, int>>{{"ubo2003", 81}, {"ubo2014", 151}}) {
    const SamplingSet set = NamedSamplingSet(name);
    EXPECT_EQ(set.name(), name);
    EXPECT_EQ(set.size(), size) << name;
  }
  // Core's names go through the same lookup.
  EXPECT_EQ(NamedSamplingSet("paper12x8").size(), 96);
  EXPECT_EQ(NamedSamplingSet("grid24x6").name(), "grid24x6");
}

TEST(UboSamplingSets, Ubo2003) {
  testing::ExpectRings(NamedSamplingSet("ubo2003"), {0, 15, 30, 45, 60, 75}, {1, 6, 12, 18, 20, 24},
                       {0, 0, 0, 0, 0, 0});
}

TEST(UboSamplingSets, Ubo2014) {
  testing::ExpectRings(NamedSamplingSet("ubo2014"), {0, 11, 23.5, 30, 37.5, 45, 52.5, 60, 67.5, 75},
                       {1, 6, 12, 12, 12, 18, 18, 24, 24, 24}, {0, 15, 0, 15, 0, 0, 7.5, 0, 7.5, 0});
}

TEST(UboSamplingSets, RejectsUnknownNamesAndBadGrids) {
  for (const std::string bad : {"ubo2015", "", "grid", "grid24", "grid24x", "gridx6", "grid024x6", "grid+2x6",
                                "grid2x6 ", "grid99999999999x1"}) {
    const std::string msg = ErrorOf([&] { NamedSamplingSet(bad); });
    EXPECT_TRUE(Contains(msg, "ubo2014") && Contains(msg, "grid<A>x<P>")) << bad << ": " << msg;
  }
  EXPECT_TRUE(Contains(ErrorOf([] { NamedSamplingSet("grid0x6"); }), "at least 1"));
}

TEST(UboSamplingSets, PassTheChecksOfEverySamplingSet) {
  std::mt19937 rng(7);
  for (const char* name : {"ubo2003", "ubo2014"}) {
    const SamplingSet set = NamedSamplingSet(name);
    testing::ExpectOrderedRingByRingThenByPhi(set);
    testing::ExpectWeightsSumToTwoPi(set);
    testing::ExpectNearestMatchesBruteForce(set, rng);
    testing::ExpectInterpolateExactAtSetDirections(set);
    testing::ExpectBlendsValid(set, rng);
    testing::ExpectInterpolateContinuous(set, rng);
    testing::ExpectJsonRoundTrip(set);
  }
}

TEST(UboSamplingSets, RingBandsAtMidpoints) {
  const SamplingSet set = NamedSamplingSet("ubo2003");
  EXPECT_NEAR(set.weight(0), 2 * testing::kPi * (1 - std::cos(7.5 * testing::kDeg)), 1e-15);  // pole cap
  EXPECT_NEAR(set.weight(1), 2 * testing::kPi * (std::cos(7.5 * testing::kDeg) - std::cos(22.5 * testing::kDeg)) / 6,
              1e-15);
  EXPECT_NEAR(set.weight(80), 2 * testing::kPi * std::cos(67.5 * testing::kDeg) / 24, 1e-15);  // last band to 90
}

TEST(UboSamplingSets, NearestAtThePole) { EXPECT_EQ(NamedSamplingSet("ubo2003").Nearest({1e-6, 0, 1}), 0); }

TEST(UboSamplingSets, ReproduceFunctionsLinearInThetaAndPhi) {
  std::mt19937 rng(5);
  testing::ExpectLinearInThetaAndPhiReproduced(NamedSamplingSet("ubo2014"), 11, 75, 15, 315, rng);
  testing::ExpectLinearInThetaAndPhiReproduced(NamedSamplingSet("ubo2003"), 15, 75, 0, 300, rng);
}

TEST(UboSamplingSets, ContinuousAcrossTheSeamAndAcrossRings) {
  const SamplingSet set = NamedSamplingSet("ubo2014");
  const auto value = [&](int i) { return testing::Smooth(set.direction(i)); };
  for (const double theta : {5.0, 11.0, 40.0, 75.0, 80.0}) {
    const double below = Blended(set.Interpolate(DirectionFromAngles(theta * testing::kDeg, -1e-9)), value);
    const double above = Blended(set.Interpolate(DirectionFromAngles(theta * testing::kDeg, 1e-9)), value);
    EXPECT_NEAR(below, above, 1e-6) << theta;
  }
  for (const double theta : {11.0, 23.5, 52.5, 75.0}) {
    const double inside = Blended(set.Interpolate(DirectionFromAngles(theta * testing::kDeg - 1e-9, 1.0)), value);
    const double outside = Blended(set.Interpolate(DirectionFromAngles(theta * testing::kDeg + 1e-9, 1.0)), value);
    EXPECT_NEAR(inside, outside, 1e-6) << theta;
  }
}

TEST(UboSamplingSets, NearThePoleWithAPoleSample) {
  const SamplingSet set = NamedSamplingSet("ubo2003");
  const auto at_pole = set.Interpolate({0, 0, 1});
  ASSERT_EQ(at_pole.count, 1);
  EXPECT_EQ(at_pole.index[0], 0);
  // The pole's weight is 1 - theta / 15 degrees whatever phi is.
  for (const double phi : {0.0, 1.0, 4.0}) {
    const auto b = set.Interpolate(DirectionFromAngles(1e-8, phi));
    testing::ExpectValidBlend(set, b);
    EXPECT_EQ(b.index[0], 0);
    EXPECT_NEAR(b.weight[0], 1 - 1e-8 / (15 * testing::kDeg), 1e-15);
  }
}

TEST(UboSamplingSets, StoredWithTheirDirections) {
  const nlohmann::json j = ToJson(NamedSamplingSet("ubo2003"));
  EXPECT_EQ(j["directions_deg"].size(), 81u);
  EXPECT_NEAR(j["directions_deg"][1][0].get<double>(), 15.0, 1e-12);
}

}  // namespace
}  // namespace mesocap::bonn
