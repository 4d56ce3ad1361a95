// Resampling displacement images to the texture grid and merging them
// (mdf/displacement_image.h, displacement_merge.h) on synthetic
// points whose every distance is known: "no hit" from points on the rig's
// backing board, and the weighted vote between distances and "no hit".
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "core/mdf.h"
#include "mdf/displacement_image.h"
#include "mdf/displacement_merge.h"

namespace mesocap::mdf {
namespace {

constexpr double kBackingMm = 8.0;

// A 20 mm sample seen straight down at 0.25 mm a pixel: a flat surface 0.5 mm
// deep with a 6 mm square hole in the middle, through which the pixels see
// the backing board.
std::vector<Eigen::Vector3f> HoleyPlane(int side, double hole_half_mm) {
  std::vector<Eigen::Vector3f> points;
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const double px = -10.0 + 20.0 * (x + 0.5) / side, py = -10.0 + 20.0 * (y + 0.5) / side;
      const bool hole = std::abs(px) < hole_half_mm && std::abs(py) < hole_half_mm;
      points.emplace_back(static_cast<float>(px), static_cast<float>(py), hole ? -kBackingMm : -0.5f);
    }
  }
  return points;
}

TEST(DisplacementImageTest, PointsOnTheBackingAreNoHitAndTheRimStaysUnknown) {
  const int side = 80;
  const calibration::TexelGrid grid{16, 16, 20.0};  // 1.25 mm texels
  TriangulationOptions options;
  options.backing_depth_mm = kBackingMm;
  const auto points = HoleyPlane(side, 3.0);
  const DisplacementImage image =
      ResampleToTexture({points, {}, {}}, side, side, Eigen::Vector3d::UnitZ(), grid, options);
  int no_hit = 0, surface = 0, unknown = 0;
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const double x = -10.0 + (i + 0.5) * grid.texel_width_mm(), y = -10.0 + (j + 0.5) * grid.texel_width_mm();
      const float d = image.at(i, j);
      const double inside = std::max(std::abs(x), std::abs(y));
      // Texel centres lie 0.625 mm + k 1.25 mm from the axes, pixel rows
      // every 0.25 mm: more than a pixel from the rim (3 mm) either side.
      if (inside < 2.5) {
        EXPECT_TRUE(core::IsNoHit(d)) << i << " " << j << " " << d;
      } else if (inside > 3.5) {
        EXPECT_NEAR(d, 0.5, 1e-5) << i << " " << j;
      }
      no_hit += core::IsNoHit(d);
      surface += std::isfinite(d);
      unknown += core::IsUnknown(d);
    }
  }
  EXPECT_EQ(no_hit, 16);         // the 4 x 4 texels inside the hole
  EXPECT_EQ(surface, 256 - 16);  // the rim lies between texel centres
  EXPECT_EQ(unknown, 0);
  // Without a board the same points are a deep surface, not a hole.
  const DisplacementImage deep =
      ResampleToTexture({points, {}, {}}, side, side, Eigen::Vector3d::UnitZ(), grid, TriangulationOptions{});
  EXPECT_NEAR(deep.at(8, 8), kBackingMm, 1e-5);
}

TEST(DisplacementImageTest, TexelsBetweenTheRimAndTheBoardAreNotFilled) {
  // Pixels every 0.125 mm, the hole's rim at 0.6 mm: texel (8, 8), centred
  // at (0.625, 0.625), lies between the last pixels on the board (0.5625)
  // and the first on the surface (0.6875). It is the surface or the hole to
  // within a pixel, so it stays unknown rather than becoming a distance that
  // would close the hole.
  const int side = 160;
  const calibration::TexelGrid grid{16, 16, 20.0};
  TriangulationOptions options;
  options.backing_depth_mm = kBackingMm;
  const DisplacementImage image =
      ResampleToTexture({HoleyPlane(side, 0.6), {}, {}}, side, side, Eigen::Vector3d::UnitZ(), grid, options);
  EXPECT_TRUE(core::IsUnknown(image.at(8, 8))) << image.at(8, 8);
  EXPECT_NEAR(image.at(10, 10), 0.5, 1e-5);
}

// A surface seen straight down, pixels every 0.5 mm (side x side over the
// 20 mm sample): each pixel's point at depth(x, y).
template <typename Depth>
std::vector<Eigen::Vector3f> SeenStraightDown(int side, Depth depth) {
  std::vector<Eigen::Vector3f> points;
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const double px = -10.0 + 0.5 * (x + 0.5), py = -10.0 + 0.5 * (y + 0.5);
      points.emplace_back(static_cast<float>(px), static_cast<float>(py), static_cast<float>(-depth(px, py)));
    }
  }
  return points;
}

TEST(DisplacementImageTest, ALoneUnknownPixelLeavesOnlyItsDiamondUnknown) {
  // A tilted plane seen straight down, pixels every 0.5 mm (40 x 40), 0.3125
  // mm texels: pixel P = (20, 20), centred at (0.25, 0.25), saw no stripe.
  // The four quads around it keep the triangles of their other three
  // corners, so every texel in the 1 mm square around P is measured (by
  // plain interpolation: the plane is exact) except inside the diamond
  // |dx| + |dy| < 0.5 mm between P's four neighbours, which no triangle of
  // measured pixels covers and which stays unknown. Before the fallback the
  // whole square was unknown.
  const int side = 40;
  const calibration::TexelGrid grid{64, 64, 20.0};
  auto depth = [](double x, double y) { return 1.0 + 0.05 * x + 0.02 * y; };
  std::vector<Eigen::Vector3f> points = SeenStraightDown(side, depth);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  points[20 * side + 20] = Eigen::Vector3f::Constant(nan);
  const DisplacementImage image =
      ResampleToTexture({points, {}, {}}, side, side, Eigen::Vector3d::UnitZ(), grid, TriangulationOptions{});
  int square = 0, diamond = 0;
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const double x = -10.0 + (i + 0.5) * grid.texel_width_mm(), y = -10.0 + (j + 0.5) * grid.texel_width_mm();
      const double dx = std::abs(x - 0.25), dy = std::abs(y - 0.25);
      // Texels inside the measured pixels' span: the outermost half pixel has no triangle.
      if (std::abs(x) > 9.75 || std::abs(y) > 9.75) continue;
      if (dx + dy < 0.5 - 1e-9) {
        EXPECT_TRUE(core::IsUnknown(image.at(i, j))) << i << " " << j << " " << image.at(i, j);
        ++diamond;
      } else {
        EXPECT_NEAR(image.at(i, j), depth(x, y), 1e-5) << i << " " << j;
        square += dx < 0.5 && dy < 0.5;
      }
    }
  }
  EXPECT_EQ(diamond, 4);  // texel centres inside the diamond
  EXPECT_EQ(square, 5);   // measured now, unknown before
}

// A step seen straight down, pixels every 0.5 mm (40 x 40), 0.3125 mm
// texels: the surface is 1 mm deep left of x = 0.3 mm and 3 mm deep right
// of it, so pixel column 20 (x in [0, 0.5]) straddles the edge. Its first
// (brighter) peak is the near surface, its second the far one. The texel
// at x = 0.469 sees the far surface: with the second points the edge is
// placed at the straddling pixels' centre (x = 0.25) and the texel is far;
// without them at the middle of columns 20 and 21 (x = 0.5), and the texel
// takes the near surface. Second points that continue no neighbour's
// surface (ghosts; here on the flat parts and a wrong depth at the edge)
// change nothing.
TEST(DisplacementImageTest, APixelStraddlingAnEdgeIsAVertexOfBothSurfaces) {
  const int side = 40;
  const calibration::TexelGrid grid{64, 64, 20.0};
  // Column 20 is x in [0, 0.5]: its first points are near.
  SweepPoints points;
  points.first = SeenStraightDown(side, [](double x, double) { return x < 0.5 ? 1.0 : 3.0; });
  points.second.assign(points.first.size(), Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN()));
  const TriangulationOptions options;
  auto texel = [&](const DisplacementImage& image, double x) {
    return image.at(static_cast<int>(std::floor((x + 10.0) / grid.texel_width_mm())), 32);
  };
  const DisplacementImage without = ResampleToTexture(points, side, side, Eigen::Vector3d::UnitZ(), grid, options);
  EXPECT_NEAR(texel(without, 0.469), 1.0, 1e-6);

  // Ghosts: far second points on the flat parts, a wrong depth at the edge.
  for (int y = 0; y < side; ++y) {
    for (int x = 0; x < side; ++x) {
      const float depth = x == 20 ? 6.0f : (x <= 20 ? 2.5f : 4.5f);
      points.second[y * side + x] = {points.first[y * side + x].x(), points.first[y * side + x].y(), -depth};
    }
  }
  // Texels whose value differs (unknown in both counts as the same).
  auto differing = [&](const DisplacementImage& a) {
    int count = 0;
    for (std::size_t t = 0; t < a.distance_mm.size(); ++t) {
      const float x = a.distance_mm[t], y = without.distance_mm[t];
      count += !(x == y || (std::isnan(x) && std::isnan(y)));
    }
    return count;
  };
  const DisplacementImage ghosts = ResampleToTexture(points, side, side, Eigen::Vector3d::UnitZ(), grid, options);
  EXPECT_EQ(differing(ghosts), 0);

  for (int y = 0; y < side; ++y) points.second[y * side + 20].z() = -3.0f;
  const DisplacementImage with = ResampleToTexture(points, side, side, Eigen::Vector3d::UnitZ(), grid, options);
  EXPECT_NEAR(texel(with, 0.469), 3.0, 1e-6);
  EXPECT_NEAR(texel(with, 0.156), 1.0, 1e-6);  // left of the straddling pixels' centre: near
  // Everything else as without.
  EXPECT_EQ(differing(with), 62);  // the texel column at x = 0.469, inside the pixels' span (|y| < 9.75)
}

// The same step without second points, with each pixel's brightness: the
// edge pixels (column 20, near) at 0.2 of their near neighbours' say that
// the near surface covers a fifth of them. The fill's boundary with column
// 21 then moves from x = 0.5 by weight x (1 - 0.2) x 0.5 mm: at the default
// weight 0.5 to x = 0.3, so the texel at x = 0.469 takes the far surface.
// A dim pixel on the far side, or a full-bright edge pixel, moves nothing.
TEST(DisplacementImageTest, ADimNearSidePixelMovesTheEdgeTowardsItsCentre) {
  const int side = 40;
  const calibration::TexelGrid grid{64, 64, 20.0};
  SweepPoints points;
  points.first = SeenStraightDown(side, [](double x, double) { return x < 0.5 ? 1.0 : 3.0; });
  auto texel = [&](const DisplacementImage& image, double x) {
    return image.at(static_cast<int>(std::floor((x + 10.0) / grid.texel_width_mm())), 32);
  };
  auto resample = [&](int dim_column, float brightness, double weight) {
    points.brightness.assign(points.first.size(), 0.8f);
    for (int y = 0; y < side; ++y) points.brightness[y * side + dim_column] = brightness;
    TriangulationOptions options;
    options.edge_shift_weight = weight;
    EXPECT_TRUE(options.Check().empty());
    return ResampleToTexture(points, side, side, Eigen::Vector3d::UnitZ(), grid, options);
  };
  const DisplacementImage midway = resample(20, 0.16f, 0.0);
  EXPECT_NEAR(texel(midway, 0.469), 1.0, 1e-6);
  const DisplacementImage moved = resample(20, 0.16f, 0.5);
  EXPECT_NEAR(texel(moved, 0.469), 3.0, 1e-6);
  EXPECT_NEAR(texel(moved, 0.156), 1.0, 1e-6);
  int differing = 0;
  for (std::size_t t = 0; t < moved.distance_mm.size(); ++t) {
    const float a = moved.distance_mm[t], b = midway.distance_mm[t];
    differing += !(a == b || (std::isnan(a) && std::isnan(b)));
  }
  EXPECT_EQ(differing, 62);  // the texel column at x = 0.469, inside the pixels' span
  EXPECT_NEAR(texel(resample(20, 0.8f, 0.5), 0.469), 1.0, 1e-6);
  EXPECT_NEAR(texel(resample(21, 0.16f, 0.5), 0.469), 1.0, 1e-6);

  TriangulationOptions bad;
  bad.edge_shift_weight = 1.5;
  EXPECT_NE(bad.Check().find("edge_shift_weight"), std::string::npos);
}

DisplacementImage OneTexel(float d) {
  DisplacementImage image;
  image.width = image.height = 1;
  image.distance_mm = {d};
  return image;
}

TEST(DisplacementMergeTest, NoHitNeedsMoreThanHalfTheWeight) {
  const float inf = core::MdfNoHit(), nan = core::MdfUnknown();
  const MergeOptions options;
  auto merge = [&](std::vector<float> values, std::vector<double> weights) {
    std::vector<DisplacementImage> images;
    for (float v : values) images.push_back(OneTexel(v));
    const MergedDisplacement m = MergeDisplacementImages(images, weights, 0.3, options);
    return std::pair{m.image.distance_mm[0], m.confidence[0]};
  };
  auto [d, c] = merge({inf, inf, 1.0f}, {1, 1, 1});
  EXPECT_TRUE(core::IsNoHit(d));
  EXPECT_NEAR(c, 2.0 / 3, 1e-6);
  std::tie(d, c) = merge({inf, 1.0f, 1.1f}, {1, 1, 1});
  EXPECT_NEAR(d, 1.05f, 1e-6);  // the no-hit vote is an outlier of the distance
  EXPECT_NEAR(c, 2.0 / 3, 1e-6);
  std::tie(d, c) = merge({inf, 1.0f}, {1, 1});
  EXPECT_NEAR(d, 1.0f, 1e-6) << "a tie goes to the distance";
  std::tie(d, c) = merge({inf, 1.0f, nan}, {3, 1, 5});
  EXPECT_TRUE(core::IsNoHit(d));
  EXPECT_NEAR(c, 3.0 / 9, 1e-6);  // of the view's whole weight, the unknown scan's included
  std::tie(d, c) = merge({nan, nan}, {1, 1});
  EXPECT_TRUE(core::IsUnknown(d));
  EXPECT_EQ(c, 0.0f);
}

}  // namespace
}  // namespace mesocap::mdf
