// Ground truth against analytic answers (the simulated-rig issue's
// acceptance): flat sample, a single box, through-holes, flat Lambertian BTF.
#include "sim/ground_truth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/mesostructure_scene.h"

namespace mesocap::sim {
namespace {

constexpr double kPi = std::numbers::pi;

core::SamplingSet Directions(std::vector<std::pair<double, double>> deg) {
  std::vector<core::SphericalAngles> a;
  for (const auto& [t, p] : deg) a.push_back({t * kPi / 180, p * kPi / 180});
  return core::SamplingSet::FromAngles("test", a);
}

TEST(GroundTruth, FlatSampleHasZeroMdfAndAlbedoOverPiBtf) {
  const auto scene = MakeBuiltinScene("flat");
  GroundTruthOptions o;
  o.texels.width = o.texels.height = 12;
  o.texels.sample_size_mm = 7.0;
  o.views = core::SamplingSet::Named("paper12x8");
  o.lights = core::SamplingSet::Named("paper12x5");
  const core::Mdf mdf = ComputeTrueMdf(*scene, o);
  for (int v = 0; v < o.views.size(); ++v)
    for (int j = 0; j < 12; ++j)
      for (int i = 0; i < 12; ++i) ASSERT_NEAR(mdf.at(i, j, v), 0.0, 1e-9);
  // Flat Lambertian, albedo 0.5: T = albedo / pi for every direction pair.
  for (int v : {0, 50, 95}) {
    const core::Image view = RenderTrueBtfView(*scene, o, v);
    for (int l = 0; l < o.lights.size(); ++l)
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(view.at(5, l * 12 + 7, c), 0.5 / kPi, 1e-6) << "v " << v << " l " << l;
  }
}

TEST(GroundTruth, AreaAveragedBtfIsTheMeanOfTheFinerGridsTexels) {
  // n x n samples a texel sit at the texel centres of the grid n times finer,
  // so each texel of the averaged BTF is the mean of an n x n block of the
  // finer grid's point-sampled one (weave: edges, shadows and holes inside
  // texels).
  const auto scene = MakeBuiltinScene("weave");
  GroundTruthOptions coarse;
  coarse.texels.width = coarse.texels.height = 6;
  coarse.texels.sample_size_mm = 10.0;
  coarse.views = Directions({{0, 0}, {60, 30}, {80, 200}});
  coarse.lights = Directions({{10, 90}, {75, 300}});
  coarse.samples_per_side = 3;
  GroundTruthOptions fine = coarse;
  fine.texels.width = fine.texels.height = 18;
  fine.samples_per_side = 1;
  double largest_spread = 0.0;  // how far a texel's samples differ: the test must see edges
  for (int v = 0; v < coarse.views.size(); ++v) {
    const core::Image averaged = RenderTrueBtfView(*scene, coarse, v);
    const core::Image points = RenderTrueBtfView(*scene, fine, v);
    for (int l = 0; l < coarse.lights.size(); ++l) {
      for (int j = 0; j < 6; ++j) {
        for (int i = 0; i < 6; ++i) {
          for (int c = 0; c < 3; ++c) {
            double sum = 0.0, low = 1e9, high = -1e9;
            for (int b = 0; b < 3; ++b) {
              for (int a = 0; a < 3; ++a) {
                const double t = points.at(3 * i + a, l * 18 + 3 * j + b, c);
                sum += t;
                low = std::min(low, t);
                high = std::max(high, t);
              }
            }
            largest_spread = std::max(largest_spread, high - low);
            ASSERT_NEAR(averaged.at(i, l * 6 + j, c), sum / 9, 1e-6)
                << "v " << v << " l " << l << " texel " << i << ", " << j;
          }
        }
      }
    }
  }
  EXPECT_GT(largest_spread, 0.05) << "no texel straddles an edge or a shadow";
  coarse.samples_per_side = 0;
  EXPECT_NE(coarse.Check(), "");
}

TEST(GroundTruth, AmbientTermIsTheLightQuadratureOfTheBtf) {
  const auto scene = MakeBuiltinScene("flat");
  GroundTruthOptions o;
  o.texels.width = o.texels.height = 4;
  o.views = core::SamplingSet::Named("grid4x2");
  o.lights = core::SamplingSet::Named("grid24x12");
  formats::AmbientTerm ambient{4, 4, o.views, core::Image(4, 4 * o.views.size(), 3)};
  for (int v = 0; v < o.views.size(); ++v)
    AccumulateAmbientTerm(RenderTrueBtfView(*scene, o, v), o.lights, v, &ambient);
  double quadrature = 0;  // sum of cos(theta_l) w_l ~ integral of cos over the hemisphere = pi
  for (int l = 0; l < o.lights.size(); ++l) quadrature += o.lights.direction(l).z() * o.lights.weight(l);
  EXPECT_NEAR(quadrature, kPi, 0.01 * kPi);
  for (int v = 0; v < o.views.size(); ++v) {
    EXPECT_NEAR(ambient.at(1, 2, v).x(), 0.5 / kPi * quadrature, 1e-5);
    EXPECT_NEAR(ambient.at(1, 2, v).x(), 0.5, 0.005) << "La of a flat Lambertian sample is its albedo";
  }
}

// The "box" scene: tile 5 mm, one box [1.5, 3.5]^2 x [-1, 0] on a base at
// z = -1. The box spans the whole depth, so the ray from p along -v hits a
// box side exactly where its horizontal path first enters a box square.
double BoxMdf(double x, double y, double theta, double phi) {
  const double reach = std::tan(theta);  // horizontal travel down to the base
  const double dx = -std::cos(phi), dy = -std::sin(phi);
  double first = std::numeric_limits<double>::infinity();
  for (int i = -4; i <= 4; ++i) {
    for (int j = -4; j <= 4; ++j) {
      // Slab test of the 2D segment against square copy (i, j).
      double lo = 0, hi = reach;
      const double box_min[2] = {1.5 + 5 * i, 1.5 + 5 * j}, box_max[2] = {3.5 + 5 * i, 3.5 + 5 * j};
      const double o[2] = {x, y}, d[2] = {dx, dy};
      bool miss = false;
      for (int k = 0; k < 2 && !miss; ++k) {
        if (std::abs(d[k]) < 1e-15) {
          miss = o[k] < box_min[k] || o[k] > box_max[k];
        } else {
          double t0 = (box_min[k] - o[k]) / d[k], t1 = (box_max[k] - o[k]) / d[k];
          if (t0 > t1) std::swap(t0, t1);
          lo = std::max(lo, t0);
          hi = std::min(hi, t1);
          miss = lo > hi;
        }
      }
      if (!miss) first = std::min(first, lo);
    }
  }
  if (first == std::numeric_limits<double>::infinity()) return 1.0 / std::cos(theta);  // the base
  return theta == 0 ? 0.0 : first / std::sin(theta);
}

TEST(GroundTruth, BoxMdfMatchesTheAnalyticAnswerEverywhere) {
  const auto scene = MakeBuiltinScene("box");
  GroundTruthOptions o;
  o.texels.width = o.texels.height = 40;
  o.texels.sample_size_mm = 13.0;                   // not a multiple of the tile: texels fall everywhere in it
  o.views = core::SamplingSet::Named("paper12x8");  // up to 84.4 degrees
  const core::Mdf mdf = ComputeTrueMdf(*scene, o);
  int beside_box = 0;
  for (int v = 0; v < o.views.size(); ++v) {
    const auto a = o.views.angles(v);
    for (int j = 0; j < 40; ++j) {
      for (int i = 0; i < 40; ++i) {
        const Eigen::Vector3d p = o.texels.TexelCentre(i, j);
        const double expected = BoxMdf(p.x(), p.y(), a.theta, a.phi);
        ASSERT_NEAR(mdf.at(i, j, v), expected, 1e-5 * expected + 1e-6) << "texel " << i << "," << j << " view " << v;
        beside_box += std::abs(expected - 1.0 / std::cos(a.theta)) < 1e-12;
      }
    }
  }
  EXPECT_GT(beside_box, 1000) << "the h / cos(theta) case must be well represented";
}

TEST(GroundTruth, BoxShadowsTheBaseAtGrazingLight) {
  const auto scene = MakeBuiltinScene("box");
  GroundTruthOptions o;
  o.texels.width = o.texels.height = 1;  // one texel, centred on the base at (0, 0)
  o.views = Directions({{0, 0}});
  // Towards the box copy at [1.5, 3.5]^2: at 75 degrees the light ray meets
  // the box side below its top; at 45 degrees it clears z = 0 before the box.
  o.lights = Directions({{75, 45}, {45, 45}});
  const core::Image view = RenderTrueBtfView(*scene, o, 0);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(view.at(0, 0, c), 0.0f) << "shadowed";
  EXPECT_NEAR(view.at(0, 1, 0), 0.45 / kPi, 1e-6);
  EXPECT_NEAR(view.at(0, 1, 1), 0.42 / kPi, 1e-6);
  EXPECT_NEAR(view.at(0, 1, 2), 0.38 / kPi, 1e-6);
}

TEST(GroundTruth, SpongeThroughHolesAreNoHit) {
  const auto scene = MakeBuiltinScene("sponge");
  GroundTruthOptions o;
  o.texels.width = o.texels.height = 48;
  o.texels.sample_size_mm = 8.0;
  o.views = Directions({{0, 0}, {70, 30}});
  const core::Mdf mdf = ComputeTrueMdf(*scene, o);
  int no_hit_vertical = 0, no_hit_grazing = 0;
  for (int j = 0; j < 48; ++j) {
    for (int i = 0; i < 48; ++i) {
      no_hit_vertical += core::IsNoHit(mdf.at(i, j, 0));
      no_hit_grazing += core::IsNoHit(mdf.at(i, j, 1));
      for (int v = 0; v < 2; ++v) {
        const float d = mdf.at(i, j, v);
        // Never "unknown", and a distance always lies within the slab.
        ASSERT_FALSE(core::IsUnknown(d));
        if (!core::IsNoHit(d)) {
          ASSERT_LE(d * std::cos(o.views.angles(v).theta), scene->d_max_mm() + 1e-6);
        }
      }
    }
  }
  EXPECT_GT(no_hit_vertical, 48 * 48 / 20) << "holes must be visible straight down";
  EXPECT_LT(no_hit_vertical, 48 * 48 * 9 / 10);
  EXPECT_LT(no_hit_grazing, no_hit_vertical) << "the slab closes the holes at grazing angles";
}

}  // namespace
}  // namespace mesocap::sim
