#include "sim/mesostructure_scene.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "core/angles.h"
#include "core/error.h"
#include "sim/builtin_scenes.h"
#include "sim/cell_walk.h"
#include "sim/tiled_scene.h"
#include "tests/sim/scene_rays.h"

namespace mesocap::sim {
namespace {

using ::testing::HasSubstr;
using namespace scene_rays;

// ---------------------------------------------------------------- Reflectance

TEST(Reflectance, DiffuseIsAlbedoOverPi) {
  Reflectance r;
  r.diffuse_albedo = {0.5f, 0.25f, 1.0f};
  const Vec n(0, 0, 1);
  const Eigen::Vector3f f = r.Evaluate(n, Omega(30, 10), Omega(70, 200));
  EXPECT_NEAR(f[0], 0.5 / kPi, 1e-7);
  EXPECT_NEAR(f[1], 0.25 / kPi, 1e-7);
  EXPECT_NEAR(f[2], 1.0 / kPi, 1e-7);
}

TEST(Reflectance, GlossyLobePeaksAtTheMirrorDirection) {
  Reflectance r;
  r.diffuse_albedo.setZero();
  r.specular_albedo = 0.4f;
  r.glossy_exponent = 30.0f;
  const Vec n(0, 0, 1);
  // Mirror pair: the half vector is the normal.
  EXPECT_NEAR(r.Evaluate(n, Omega(40, 0), Omega(40, 180))[0], 0.4 * 38.0 / (8.0 * kPi), 1e-6);
  // Off the mirror direction the lobe is (n.h)^e of its peak.
  const Vec wi = Omega(40, 0), wo = Omega(20, 180);
  const double cos_h = n.dot((wi + wo).normalized());
  EXPECT_NEAR(r.Evaluate(n, wi, wo)[1], 0.4 * 38.0 / (8.0 * kPi) * std::pow(cos_h, 30.0), 1e-6);
}

TEST(Reflectance, IsZeroBelowTheSurface) {
  const Reflectance r;
  const Vec n(0, 0, 1);
  EXPECT_EQ(r.Evaluate(n, Omega(100, 0), Omega(20, 0)), Eigen::Vector3f::Zero());
  EXPECT_EQ(r.Evaluate(n, Omega(20, 0), Omega(95, 0)), Eigen::Vector3f::Zero());
}

// ---------------------------------------------------------------- cell walk

TEST(CellWalk, SpansAreContiguousAndCountTheBordersCrossed) {
  constexpr double kP = 5.0, kDepth = 1.0;
  for (const double theta : {0.0, 30.0, 75.0, 89.0}) {
    for (const double phi : {0.0, 37.0, 135.0, 270.0}) {
      const Vec origin(1.3, -2.2, 0.0);
      const Vec dir = -Omega(theta, phi);
      CellWalk walk(origin, dir, 0.0, kInf, kP, kDepth);
      std::vector<CellSpan> spans;
      CellSpan span;
      while (walk.Next(&span)) spans.push_back(span);
      ASSERT_FALSE(spans.empty());
      const double t_exit = kDepth / std::cos(theta * kDeg);
      EXPECT_DOUBLE_EQ(spans.front().t_begin, 0.0);
      EXPECT_NEAR(spans.back().t_end, t_exit, 1e-9 * t_exit);
      const Vec end = origin + t_exit * dir;
      const auto crossings = [&](int axis) {
        return std::abs(std::floor(end[axis] / kP) - std::floor(origin[axis] / kP));
      };
      EXPECT_EQ(spans.size(), crossings(0) + crossings(1) + 1) << theta << " " << phi;
      for (std::size_t k = 0; k < spans.size(); ++k) {
        if (k > 0) {
          EXPECT_EQ(spans[k].t_begin, spans[k - 1].t_end);
        }
        const Vec mid = origin + 0.5 * (spans[k].t_begin + spans[k].t_end) * dir;
        EXPECT_EQ(std::floor(mid.x() / kP), spans[k].i);
        EXPECT_EQ(std::floor(mid.y() / kP), spans[k].j);
      }
    }
  }
}

TEST(CellWalk, StopsAtTheCapForAHorizontalRayInTheSlab) {
  CellWalk walk(Vec(0.3, 0.4, -0.5), Vec(1, 0, 0), 0.0, kInf, 5.0, 1.0);
  int cells = 0;
  CellSpan span;
  while (walk.Next(&span)) ++cells;
  EXPECT_EQ(cells, kMaxCellsPerRay);
}

TEST(CellWalk, NothingOutsideTheSlab) {
  CellSpan span;
  EXPECT_FALSE(CellWalk(Vec(0, 0, 0.5), Vec(1, 0, 0), 0.0, kInf, 5.0, 1.0).Next(&span));
  EXPECT_FALSE(CellWalk(Vec(0, 0, 0.5), Vec(0, 0, 1), 0.0, kInf, 5.0, 1.0).Next(&span));
  EXPECT_FALSE(CellWalk(Vec(0, 0, 2.0), Vec(0, 0, -1), 0.0, 1.5, 5.0, 1.0).Next(&span));  // t_max short
}

// ---------------------------------------------------------------- flat

TEST(FlatScene, VerticalAndObliqueRaysHitThePlane) {
  const auto scene = MakeBuiltinScene("flat");
  const auto vertical = scene->Intersect(Vec(1.3, 2.7, 2.0), Vec(0, 0, -1), 0.0, kInf);
  ASSERT_TRUE(vertical);
  EXPECT_NEAR(vertical->distance, 2.0, 1e-12);
  EXPECT_NEAR(vertical->point.z(), 0.0, 1e-12);
  EXPECT_NEAR((vertical->normal - Vec(0, 0, 1)).norm(), 0.0, 1e-12);

  const auto oblique = scene->Intersect(Vec(0.2, -7.1, 2.0), -Omega(60, 30), 0.0, kInf);
  ASSERT_TRUE(oblique);
  EXPECT_NEAR(oblique->distance, 4.0, 1e-12);
  EXPECT_NEAR(oblique->point.z(), 0.0, 1e-12);

  // A flat Lambertian BTF: albedo / pi for every pair of directions.
  const Eigen::Vector3f f = oblique->reflectance.Evaluate(oblique->normal, Omega(30, 0), Omega(60, 90));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(f[c], 0.5 / kPi, 1e-7);
}

TEST(FlatScene, MdfIsZero) {
  const auto scene = MakeBuiltinScene("flat");
  std::mt19937_64 rng(1);
  for (int k = 0; k < 100; ++k) {
    const Vec p(Uniform(rng, -10, 10), Uniform(rng, -10, 10), 0.0);
    const auto d = Distance(*scene, p, -Omega(Uniform(rng, 0, 89), Uniform(rng, 0, 360)));
    ASSERT_TRUE(d);
    EXPECT_EQ(*d, 0.0);
  }
}

// ---------------------------------------------------------------- box

// The box scene analytically (documented in mesostructure_scene.h): base
// z = -1 everywhere, boxes [1.5, 3.5]^2 x [-1, 0] with period 5. For rays
// that start outside the boxes.
std::optional<double> BoxTruth(const Vec& o, const Vec& d, double t_min, double t_max) {
  double best = kInf;
  if (d.z() != 0.0) {
    const double t = (-1.0 - o.z()) / d.z();
    if (t >= t_min && t <= t_max) best = t;
  }
  // Boxes whose cells the segment can reach within the slab.
  const double t_far = std::min(t_max, d.z() != 0.0 ? std::max(-o.z() / d.z(), (-1.0 - o.z()) / d.z()) : 100.0);
  const Vec a = o + t_min * d, b = o + t_far * d;
  for (int i = static_cast<int>(std::floor(std::min(a.x(), b.x()) / 5.0)) - 1;
       i <= static_cast<int>(std::floor(std::max(a.x(), b.x()) / 5.0)) + 1; ++i) {
    for (int j = static_cast<int>(std::floor(std::min(a.y(), b.y()) / 5.0)) - 1;
         j <= static_cast<int>(std::floor(std::max(a.y(), b.y()) / 5.0)) + 1; ++j) {
      const Vec lo(1.5 + 5.0 * i, 1.5 + 5.0 * j, -1.0), hi(3.5 + 5.0 * i, 3.5 + 5.0 * j, 0.0);
      double enter = -kInf, leave = kInf;
      for (int k = 0; k < 3; ++k) {
        if (d[k] == 0.0) {
          if (o[k] < lo[k] || o[k] > hi[k]) enter = kInf;
          continue;
        }
        const double t0 = (lo[k] - o[k]) / d[k], t1 = (hi[k] - o[k]) / d[k];
        enter = std::max(enter, std::min(t0, t1));
        leave = std::min(leave, std::max(t0, t1));
      }
      if (enter <= leave && enter >= t_min && enter <= t_max) best = std::min(best, enter);
    }
  }
  if (best == kInf) return std::nullopt;
  return best;
}

TEST(BoxScene, BaseBesideTheBoxIsAtHOverCosTheta) {
  const auto scene = MakeBuiltinScene("box");
  constexpr double kH = 1.0;
  // Along the lines y = 0.5 and x = 0.5 no box is ever in the way, however
  // many tiles the ray crosses: up to 89.99 degrees (~1100 tiles).
  for (const double theta : {0.0, 10.0, 30.0, 45.0, 60.0, 75.0, 85.0, 89.0, 89.9, 89.99}) {
    for (const auto& [origin, phi] : {std::pair{Vec(4.0, 0.5, 0.0), 0.0}, std::pair{Vec(4.0, 0.5, 0.0), 180.0},
                                      std::pair{Vec(0.5, -3.0, 0.0), 90.0}}) {
      const auto hit = scene->Intersect(origin, -Omega(theta, phi), 0.0, kInf);
      ASSERT_TRUE(hit) << theta;
      const double expected = kH / std::cos(theta * kDeg);
      EXPECT_NEAR(hit->distance, expected, 1e-9 * expected) << "theta " << theta << " phi " << phi;
      EXPECT_NEAR(hit->normal.z(), 1.0, 1e-12);
      EXPECT_NEAR(hit->point.z(), -kH, 1e-9);
    }
  }
}

// The interval is closed at t_max too: a floor exactly at t_max is hit even
// though Embree holds the ray length in single precision.
TEST(BoxScene, FloorExactlyAtTMaxIsHit) {
  const auto scene = MakeBuiltinScene("box");
  std::mt19937_64 rng(3);
  int misses = 0;
  for (int k = 0; k < 2000; ++k) {
    // Base points beside the box, oblique rays down to the base at z = -1.
    const Vec origin(Uniform(rng, 0.0, 1.4), Uniform(rng, 0.0, 1.4), 0.0);
    // Away from the box: at most tan(40 deg) = 0.84 mm sideways, short of the next copy.
    const Vec dir = -Omega(Uniform(rng, 0.0, 40.0), Uniform(rng, 0.0, 90.0));
    const double t_floor = 1.0 / -dir.z();
    const auto hit = scene->Intersect(origin, dir, 0.0, t_floor);
    if (!hit) {
      ++misses;
      continue;
    }
    EXPECT_NEAR(hit->distance, t_floor, 1e-9);
    // Just short of the floor there is nothing.
    EXPECT_FALSE(scene->Intersect(origin, dir, 0.0, t_floor - 1e-6).has_value());
  }
  EXPECT_EQ(misses, 0);
}

TEST(BoxScene, TopIsAtDistanceZero) {
  const auto scene = MakeBuiltinScene("box");
  EXPECT_EQ(Distance(*scene, Vec(2.5, 2.5, 0.0), Vec(0, 0, -1)), 0.0);
  EXPECT_EQ(Distance(*scene, Vec(2.0 + 5.0, 3.0 - 10.0, 0.0), -Omega(45, 120)), 0.0);
  EXPECT_NEAR(*Distance(*scene, Vec(2.5, 2.5, 1.0), Vec(0, 0, -1)), 1.0, 1e-12);
}

TEST(BoxScene, WallHitHasTheWallNormal) {
  const auto scene = MakeBuiltinScene("box");
  // From (0.5, 2.5) towards +x at 60 degrees: the wall x = 1.5 at z = -cot(60).
  const auto hit = scene->Intersect(Vec(0.5, 2.5, 0.0), -Omega(60, 180), 0.0, kInf);
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->distance, 1.0 / std::sin(60 * kDeg), 1e-12);
  EXPECT_NEAR((hit->normal - Vec(-1, 0, 0)).norm(), 0.0, 1e-12);
}

TEST(BoxScene, MatchesTheAnalyticSceneOnRandomRays) {
  const auto scene = MakeBuiltinScene("box");
  std::mt19937_64 rng(7);
  for (int k = 0; k < 3000; ++k) {
    const Vec p(Uniform(rng, -20, 20), Uniform(rng, -20, 20), 0.0);
    const Vec dir = -Omega(Uniform(rng, 0, 85), Uniform(rng, 0, 360));
    const auto truth = BoxTruth(p, dir, 0.0, kInf);
    const auto d = Distance(*scene, p, dir);
    ASSERT_EQ(d.has_value(), truth.has_value()) << k;
    if (d) {
      EXPECT_NEAR(*d, *truth, 1e-9 * (1.0 + *truth)) << k;
    }
  }
}

TEST(BoxScene, RaysParallelToAWallPassBesideItOrHitTheNextFace) {
  const auto scene = MakeBuiltinScene("box");
  // In planes 1e-5 mm outside and inside the wall x = 1.5, moving along +y.
  // (Which face is met is decided in single precision: offsets below ~1e-6
  // mm are not resolved; see mesostructure_scene.h.)
  for (const double x : {1.5 - 1e-5, 1.5 + 1e-5}) {
    for (const double theta : {30.0, 60.0, 80.0}) {
      const Vec origin(x, 0.2, 0.0);
      const Vec dir = -Omega(theta, 270);
      const auto truth = BoxTruth(origin, dir, 0.0, kInf);
      ASSERT_TRUE(truth);
      const auto d = Distance(*scene, origin, dir);
      ASSERT_TRUE(d);
      EXPECT_NEAR(*d, *truth, 1e-9) << x << " " << theta;
    }
  }
}

TEST(BoxScene, RaysAlongCellBordersAndThroughTileCorners) {
  const auto scene = MakeBuiltinScene("box");
  // Down the corners where four copies of the base meet (watertight seams).
  for (const Vec& corner : {Vec(0, 0, 1), Vec(5, 5, 1), Vec(-5, 10, 1), Vec(0, 2.5 - 5, 1)}) {
    EXPECT_NEAR(*Distance(*scene, corner, Vec(0, 0, -1)), 2.0, 1e-12) << corner.transpose();
  }
  // In the border plane x = 0 and along the diagonal through the corners.
  for (const double theta : {20.0, 70.0, 88.0}) {
    const double expected = 1.0 / std::cos(theta * kDeg);
    EXPECT_NEAR(*Distance(*scene, Vec(0, 0.7, 0), -Omega(theta, 270)), expected, 1e-9 * expected);
    EXPECT_NEAR(*Distance(*scene, Vec(0, 0, 0), -Omega(theta, 225)),
                *BoxTruth(Vec(0, 0, 0), -Omega(theta, 225), 0, kInf), 1e-9 * expected);
  }
}

TEST(BoxScene, HorizontalRaysTerminate) {
  const auto scene = MakeBuiltinScene("box");
  // In the free gap between the rows of boxes: never a hit; cut off after kMaxCellsPerRay tiles.
  EXPECT_FALSE(scene->Intersect(Vec(0, 0.5, -0.5), Vec(1, 0, 0), 0.0, kInf));
  EXPECT_FALSE(scene->Occluded(Vec(0, 0.5, -0.5), Vec(1, 0, 0), 0.0, kInf));
  // Towards a wall.
  EXPECT_NEAR(*Distance(*scene, Vec(0, 2.5, -0.5), Vec(1, 0, 0)), 1.5, 1e-12);
  // Beyond the cap (89.999 degrees needs ~11500 tiles here): reported as no hit.
  EXPECT_FALSE(scene->Intersect(Vec(4.0, 0.5, 0.0), -Omega(89.999, 0), 0.0, kInf));
  // In the plane of the box tops and of the base: rays in a face's plane end somewhere on that face's edges,
  // or nowhere.
  const auto on_top = scene->Intersect(Vec(0, 2.5, 0.0), Vec(1, 0, 0), 0.0, kInf);
  if (on_top) {
    EXPECT_NEAR(on_top->point.z(), 0.0, 1e-9);
    EXPECT_NEAR(std::remainder(on_top->point.x() - 2.5, 5.0), 0.0, 1.0 + 1e-9);
  }
  scene->Intersect(Vec(0.3, 0.5, -1.0), Omega(90, 33), 0.0, kInf);  // must return
}

TEST(BoxScene, ShadowRaysFromTheBaseDoNotSeeTheirOwnSurface) {
  const auto scene = MakeBuiltinScene("box");
  const double eps = scene->surface_epsilon_mm();
  EXPECT_GT(eps, 1e-5);
  EXPECT_LT(eps, 1e-3);
  std::mt19937_64 rng(3);
  int tested = 0;
  while (tested < 2000) {
    const Vec p(Uniform(rng, 0, 5), Uniform(rng, 0, 5), -1.0);
    if (p.x() > 1.5 && p.x() < 3.5 && p.y() > 1.5 && p.y() < 3.5) continue;  // under the box
    ++tested;
    // Elevations down to 1 degree above the base.
    const Vec dir = Omega(Uniform(rng, 0, 89), Uniform(rng, 0, 360));
    const bool truth = BoxTruth(p, dir, eps, kInf).has_value();
    EXPECT_EQ(scene->Occluded(p, dir, eps, kInf), truth) << p.transpose() << " / " << dir.transpose();
    EXPECT_EQ(scene->Intersect(p, dir, eps, kInf).has_value(), truth);
  }
}

// ---------------------------------------------------------------- other scenes

TEST(SpongeScene, RayDownAHoleLeavesTheSlab) {
  const auto scene = MakeBuiltinScene("sponge");
  for (const Vec& hole : {Vec(2, 1, 1), Vec(2 + 4, 1 - 8, 1), Vec(0, 3, 1)}) {
    EXPECT_FALSE(scene->Intersect(hole, Vec(0, 0, -1), 0.0, kInf)) << hole.transpose();
    EXPECT_FALSE(scene->Occluded(hole, Vec(0, 0, -1), 0.0, kInf));
  }
  // On a top bar (this one crosses the tile border y = 0) and on a bottom bar.
  EXPECT_NEAR(*Distance(*scene, Vec(2, 0, 1), Vec(0, 0, -1)), 1.0, 1e-12);
  EXPECT_NEAR(*Distance(*scene, Vec(2, -0.3, 1), Vec(0, 0, -1)), 1.0, 1e-12);
  EXPECT_NEAR(*Distance(*scene, Vec(1, 1, 1), Vec(0, 0, -1)), 1.6, 1e-12);
}

TEST(BrickScene, BrickAcrossTheTileBorderIsWhole) {
  const auto scene = MakeBuiltinScene("brick");
  // Course 1 (y in [2.2, 3.8]) has a brick over x in [6.2, 9.8]: it crosses x = P = 8.
  for (const double x : {8.0 - 1e-12, 8.0, 8.0 + 1e-12, 9.7, 0.0, 16.0}) {
    EXPECT_NEAR(*Distance(*scene, Vec(x, 3.0, 1), Vec(0, 0, -1)), 1.0, 1e-12) << x;
  }
  EXPECT_NEAR(*Distance(*scene, Vec(6.0, 3.0, 1), Vec(0, 0, -1)), 1.5, 1e-12);  // mortar joint
}

TEST(WeaveScene, IsNotAHeightField) {
  const auto scene = MakeBuiltinScene("weave");
  // Over the crossing (1, 1) the warp thread (along x) lies over the weft.
  EXPECT_NEAR(*Distance(*scene, Vec(1, 1, 1), Vec(0, 0, -1)), 1.0, 1e-9);
  // In the 0.1 mm gap between them, at z = -1.25: the warp's underside is
  // above, the weft's top below: free space under a surface.
  const auto up = scene->Intersect(Vec(1, 1, -1.25), Vec(0, 0, 1), 0.0, kInf);
  const auto down = scene->Intersect(Vec(1, 1, -1.25), Vec(0, 0, -1), 0.0, kInf);
  ASSERT_TRUE(up);
  ASSERT_TRUE(down);
  EXPECT_NEAR(up->distance, 0.05, 1e-9);
  EXPECT_NEAR(down->distance, 0.05, 1e-9);
  EXPECT_LT(up->normal.z(), -0.99);  // a face looking down
  // Under the weft, above the backing: more free space.
  const auto under = scene->Intersect(Vec(1, 1, -2.9), Vec(0, 0, 1), 0.0, kInf);
  ASSERT_TRUE(under);
  EXPECT_NEAR(under->distance, 0.4, 1e-9);
  EXPECT_NEAR(*Distance(*scene, Vec(1, 1, -2.9), Vec(0, 0, -1)), 0.1, 1e-9);
}

TEST(PipesScene, HasUndercuts) {
  const auto scene = MakeBuiltinScene("pipes");
  EXPECT_NEAR(*Distance(*scene, Vec(2.0, 1.5, 1.0), Vec(0, 0, -1)), 1.0, 1e-9);  // the top of pipe A
  const auto under = scene->Intersect(Vec(2.0, 1.5, -2.5), Vec(0, 0, 1), 0.0, kInf);
  ASSERT_TRUE(under);
  EXPECT_NEAR(under->distance, 0.5, 1e-9);
  EXPECT_LT(under->normal.z(), -0.99);
}

TEST(PipesScene, SurfaceRaysDoNotSeeTheirOwnSurface) {
  const auto scene = MakeBuiltinScene("pipes");
  const double eps = scene->surface_epsilon_mm();
  std::mt19937_64 rng(11);
  for (int k = 0; k < 2000; ++k) {
    // A point on pipe A from above, then rays leaving it at least 1 degree above its facet.
    const auto hit = scene->Intersect(Vec(Uniform(rng, 0, 6), Uniform(rng, 0.7, 2.3), 1.0), Vec(0, 0, -1), 0, kInf);
    ASSERT_TRUE(hit);
    Vec dir = RandomUnit(rng);
    if (dir.dot(hit->normal) < 0) dir = -dir;
    if (dir.dot(hit->normal) < std::sin(1.0 * kDeg)) continue;
    const auto next = scene->Intersect(hit->point, dir, eps, kInf);
    // Pipe A is convex: whatever the ray meets next is far from the start.
    if (next) {
      EXPECT_GT(next->distance, 0.1) << k;
    }
  }
}

TEST(GrassScene, ThinBladesHideSomeOfTheSoil) {
  const auto scene = MakeBuiltinScene("grass");
  int soil = 0, blade = 0;
  for (int i = 0; i < 100; ++i) {
    for (int j = 0; j < 100; ++j) {
      const auto hit = scene->Intersect(Vec(0.04 * i + 0.013, 0.04 * j + 0.017, 1), Vec(0, 0, -1), 0, kInf);
      ASSERT_TRUE(hit);
      (hit->point.z() < -scene->d_max_mm() + 1e-9 ? soil : blade)++;
    }
  }
  EXPECT_GT(blade, 50);
  EXPECT_GT(soil, 7000);
}

// ---------------------------------------------------------------- all built-in scenes

class EveryScene : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryScene, HitsLieInTheSlabAndFaceTheRay) {
  const auto scene = MakeBuiltinScene(GetParam());
  EXPECT_EQ(scene->name(), GetParam());
  EXPECT_GT(scene->tile_size_mm(), 0.0);
  EXPECT_GT(scene->d_max_mm(), 0.0);
  std::mt19937_64 rng(5);
  const double p = scene->tile_size_mm();
  for (int k = 0; k < 2000; ++k) {
    const Vec origin(Uniform(rng, -p, 2 * p), Uniform(rng, -p, 2 * p), 0.0);
    const Vec dir = -Omega(Uniform(rng, 0, 89), Uniform(rng, 0, 360));
    const auto hit = scene->Intersect(origin, dir, 0.0, kInf);
    if (!hit) continue;
    EXPECT_GE(hit->point.z(), -scene->d_max_mm() - 1e-9);
    EXPECT_LE(hit->point.z(), 1e-9);
    EXPECT_NEAR((hit->point - (origin + hit->distance * dir)).norm(), 0.0, 1e-12);
    EXPECT_NEAR(hit->normal.norm(), 1.0, 1e-12);
    EXPECT_LE(hit->normal.dot(dir), 0.0);
    EXPECT_GE(hit->reflectance.diffuse_albedo.minCoeff(), 0.0f);
    EXPECT_LE(hit->reflectance.diffuse_albedo.maxCoeff(), 1.0f);
  }
}

TEST_P(EveryScene, TopTouchesTheReferencePlane) {
  if (GetParam() == "grass") {
    // The tallest blade's tip is a single point that vertical rays cannot
    // find; check the geometry itself instead.
    double top = -kInf;
    for (const auto& v : BuiltinTileGeometry("grass").vertices) top = std::max(top, v.z());
    EXPECT_NEAR(top, 0.0, 1e-12);
    return;
  }
  const auto scene = MakeBuiltinScene(GetParam());
  double highest = -kInf;
  for (int i = 0; i < 64; ++i) {
    for (int j = 0; j < 64; ++j) {
      const Vec origin(scene->tile_size_mm() * i / 64.0, scene->tile_size_mm() * j / 64.0, 1.0);
      const auto hit = scene->Intersect(origin, Vec(0, 0, -1), 0.0, kInf);
      if (hit) highest = std::max(highest, hit->point.z());
    }
  }
  EXPECT_NEAR(highest, 0.0, 1e-9);
}

TEST_P(EveryScene, IsPeriodic) {
  const auto scene = MakeBuiltinScene(GetParam());
  const double p = scene->tile_size_mm();
  std::mt19937_64 rng(9);
  for (int k = 0; k < 500; ++k) {
    const Vec origin(Uniform(rng, 0, p), Uniform(rng, 0, p), Uniform(rng, -scene->d_max_mm(), 0.5));
    const Vec dir = RandomUnit(rng);
    const auto hit = scene->Intersect(origin, dir, 0.0, kInf);
    for (const Vec& shift : {Vec(p, 0, 0), Vec(0, p, 0), Vec(-3 * p, 7 * p, 0)}) {
      const auto shifted = scene->Intersect(origin + shift, dir, 0.0, kInf);
      ASSERT_EQ(shifted.has_value(), hit.has_value()) << k;
      if (!hit) continue;
      EXPECT_NEAR(shifted->distance, hit->distance, 1e-9 * (1.0 + hit->distance));
      EXPECT_NEAR((shifted->normal - hit->normal).norm(), 0.0, 1e-9);
      EXPECT_NEAR((shifted->reflectance.diffuse_albedo - hit->reflectance.diffuse_albedo).norm(), 0.0, 1e-5);
    }
  }
}

TEST_P(EveryScene, OccludedAgreesWithIntersect) {
  const auto scene = MakeBuiltinScene(GetParam());
  const double p = scene->tile_size_mm(), d = scene->d_max_mm();
  std::mt19937_64 rng(13);
  for (int k = 0; k < 3000; ++k) {
    const Vec origin(Uniform(rng, -p, 2 * p), Uniform(rng, -p, 2 * p), Uniform(rng, -d - 0.3, 0.5));
    const Vec dir = RandomUnit(rng);
    const double t_min = k % 3 == 0 ? 0.0 : k % 3 == 1 ? scene->surface_epsilon_mm() : Uniform(rng, 0, 1);
    const double t_max = k % 2 == 0 ? kInf : t_min + Uniform(rng, 0, 3 * p);
    const auto hit = scene->Intersect(origin, dir, t_min, t_max);
    EXPECT_EQ(scene->Occluded(origin, dir, t_min, t_max), hit.has_value()) << k;
    if (hit) {
      EXPECT_GE(hit->distance, t_min);
      EXPECT_LE(hit->distance, t_max);
    }
  }
}

TEST_P(EveryScene, GrazingRaysTerminate) {
  const auto scene = MakeBuiltinScene(GetParam());
  std::mt19937_64 rng(17);
  for (const double theta : {85.0, 88.0, 89.0, 89.9, 90.0}) {
    for (int k = 0; k < 50; ++k) {
      const double z = theta == 90.0 ? Uniform(rng, -scene->d_max_mm(), 0) : 0.0;
      const Vec origin(Uniform(rng, 0, 10), Uniform(rng, 0, 10), z);
      const Vec dir = -Omega(theta, Uniform(rng, 0, 360));
      const auto hit = scene->Intersect(origin, dir, 0.0, kInf);
      if (hit) {
        EXPECT_GE(hit->distance, 0.0);
      }
      scene->Occluded(origin, dir, 0.0, kInf);
    }
  }
}

TEST_P(EveryScene, IsDeterministic) {
  const auto a = MakeBuiltinScene(GetParam());
  const auto b = MakeBuiltinScene(GetParam());
  std::mt19937_64 rng(19);
  for (int k = 0; k < 200; ++k) {
    const Vec origin(Uniform(rng, 0, 10), Uniform(rng, 0, 10), 0.0);
    const Vec dir = -Omega(Uniform(rng, 0, 80), Uniform(rng, 0, 360));
    const auto ha = a->Intersect(origin, dir, 0.0, kInf);
    const auto hb = b->Intersect(origin, dir, 0.0, kInf);
    ASSERT_EQ(ha.has_value(), hb.has_value());
    if (!ha) continue;
    EXPECT_EQ(ha->distance, hb->distance);
    EXPECT_EQ(ha->reflectance.diffuse_albedo, hb->reflectance.diffuse_albedo);
  }
}

// Brute force in double precision (Moller-Trumbore): every triangle of the
// 5 x 5 tiles around the origin whose bounding box meets the ray's footprint
// in the slab; for downward rays from z = 0 that stay within two tiles.
class BruteForce {
 public:
  explicit BruteForce(const TileGeometry& g) : g_(g) {
    for (const Eigen::Vector3i& tri : g.triangles) {
      const Vec& a = g.vertices[tri[0]];
      const Vec& b = g.vertices[tri[1]];
      const Vec& c = g.vertices[tri[2]];
      lo_.push_back(a.cwiseMin(b).cwiseMin(c).head<2>());
      hi_.push_back(a.cwiseMax(b).cwiseMax(c).head<2>());
    }
  }

  std::optional<double> Intersect(const Vec& o, const Vec& d) const {
    const double p = g_.tile_size_mm;
    const Vec end = o + (g_.d_max_mm / -d.z()) * d;
    const Eigen::Vector2d lo = o.cwiseMin(end).head<2>().array() - 1e-6;
    const Eigen::Vector2d hi = o.cwiseMax(end).head<2>().array() + 1e-6;
    double best = kInf;
    for (int sy = -2; sy <= 2; ++sy) {
      for (int sx = -2; sx <= 2; ++sx) {
        const Eigen::Vector2d shift((std::floor(o.x() / p) + sx) * p, (std::floor(o.y() / p) + sy) * p);
        // Tile geometry stays within half a period of its tile (CheckTileGeometry).
        if ((shift.array() + 1.5 * p < lo.array()).any() || (shift.array() - 0.5 * p > hi.array()).any()) continue;
        for (std::size_t k = 0; k < g_.triangles.size(); ++k) {
          if (((hi_[k] + shift).array() < lo.array()).any() || ((lo_[k] + shift).array() > hi.array()).any()) {
            continue;
          }
          const Eigen::Vector3i& tri = g_.triangles[k];
          const Vec a = g_.vertices[tri[0]] + Vec(shift.x(), shift.y(), 0.0);
          const Vec e1 = g_.vertices[tri[1]] - g_.vertices[tri[0]];
          const Vec e2 = g_.vertices[tri[2]] - g_.vertices[tri[0]];
          const Vec pv = d.cross(e2);
          const double det = e1.dot(pv);
          if (det == 0.0) continue;
          const Vec tv = o - a;
          const Vec qv = tv.cross(e1);
          const double u = tv.dot(pv) / det, v = d.dot(qv) / det, t = e2.dot(qv) / det;
          if (u >= 0 && v >= 0 && u + v <= 1 && t >= 0) best = std::min(best, t);
        }
      }
    }
    if (best == kInf) return std::nullopt;
    return best;
  }

 private:
  const TileGeometry& g_;
  std::vector<Eigen::Vector2d> lo_, hi_;  // per triangle, in the tile
};

TEST_P(EveryScene, MatchesBruteForce) {
  const TileGeometry geometry = BuiltinTileGeometry(GetParam());
  const BruteForce brute_force(geometry);
  const auto scene = MakeBuiltinScene(GetParam());
  const double p = geometry.tile_size_mm;
  std::mt19937_64 rng(23);
  int hits = 0;
  for (int k = 0; k < 300; ++k) {
    const Vec origin(Uniform(rng, 0, p), Uniform(rng, 0, p), 0.0);
    const Vec dir = -Omega(Uniform(rng, 0, 60), Uniform(rng, 0, 360));
    const auto truth = brute_force.Intersect(origin, dir);
    const auto d = Distance(*scene, origin, dir);
    ASSERT_EQ(d.has_value(), truth.has_value()) << k << ": " << origin.transpose() << " / " << dir.transpose();
    if (!d) continue;
    ++hits;
    EXPECT_NEAR(*d, *truth, 1e-9 * (1.0 + *truth)) << k;
  }
  EXPECT_GT(hits, 100);
}

INSTANTIATE_TEST_SUITE_P(Builtin, EveryScene, ::testing::ValuesIn(BuiltinSceneNames()),
                         [](const auto& info) { return info.param; });

TEST(TiledScene, RejectsGeometryReachingBeyondTheNeighbouringTiles) {
  // The tracer sees only the tile and its 8 neighbours: objects must stay
  // within half a period of their tile, and inside the slab.
  TileGeometry g{.name = "too wide", .tile_size_mm = 2.0, .d_max_mm = 1.0};
  const int part = g.AddPart(Reflectance{});
  g.AddTriangle(g.AddVertex({0, 0, 0}), g.AddVertex({3.5, 0, 0}), g.AddVertex({0, 1, 0}), part);
  EXPECT_THROW(MakeTiledScene(g), std::logic_error);
  g.vertices[1] = {1, 0, -1.5};
  EXPECT_THROW(MakeTiledScene(g), std::logic_error);
  g.vertices[1] = {1, 0, -1.0};
  EXPECT_NO_THROW(MakeTiledScene(g));
}

TEST(BuiltinScenes, UnknownNameListsTheKnownOnes) {
  try {
    MakeBuiltinScene("marble");
    FAIL();
  } catch (const core::Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("marble"));
    EXPECT_THAT(e.what(), HasSubstr("weave"));
  }
}

}  // namespace
}  // namespace mesocap::sim
