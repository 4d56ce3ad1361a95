// The texel grid on the sample's clipped square (docs/FORMATS.md "Texture
// grid"): texel centres in the sample frame and their inverse.
#include "calibration/texel_grid.h"

#include <gtest/gtest.h>

namespace mesocap::calibration {
namespace {

TEST(TexelGridTest, CentresTileTheClippedSquare) {
  const TexelGrid grid{4, 2, 20.0};
  EXPECT_DOUBLE_EQ(grid.texel_width_mm(), 5.0);
  EXPECT_DOUBLE_EQ(grid.texel_height_mm(), 10.0);
  // Column 0 is the -X edge's texel, row 0 the -Y edge's; all on z = 0.
  EXPECT_TRUE(grid.TexelCentre(0, 0).isApprox(Eigen::Vector3d(-7.5, -5.0, 0.0)));
  EXPECT_TRUE(grid.TexelCentre(3, 1).isApprox(Eigen::Vector3d(7.5, 5.0, 0.0)));
  EXPECT_EQ(grid.TexelCentre(2, 1).z(), 0.0);
  // Neighbouring centres are a texel apart, and the grid is centred.
  EXPECT_NEAR(grid.TexelCentre(2, 0).x() - grid.TexelCentre(1, 0).x(), grid.texel_width_mm(), 1e-12);
  EXPECT_NEAR(grid.TexelCentre(1, 0).x() + grid.TexelCentre(2, 0).x(), 0.0, 1e-12);
}

TEST(TexelGridTest, TexelCoordinatesInvertTheCentres) {
  for (const TexelGrid& grid : {TexelGrid{64, 64, 20.0}, TexelGrid{7, 13, 3.3}}) {
    for (int j = 0; j < grid.height; ++j) {
      for (int i = 0; i < grid.width; ++i) {
        const Eigen::Vector3d p = grid.TexelCentre(i, j);
        const Eigen::Vector2d uv = grid.TexelCoordinates(p.x(), p.y());
        EXPECT_NEAR(uv.x(), i, 1e-9) << i << " " << j;
        EXPECT_NEAR(uv.y(), j, 1e-9) << i << " " << j;
      }
    }
    // The square's corners lie half a texel outside the outer centres.
    const double half = 0.5 * grid.sample_size_mm;
    EXPECT_NEAR(grid.TexelCoordinates(-half, -half).x(), -0.5, 1e-9);
    EXPECT_NEAR(grid.TexelCoordinates(half, half).y(), grid.height - 0.5, 1e-9);
  }
}

TEST(TexelGridTest, CheckNamesTheBadField) {
  EXPECT_TRUE(TexelGrid{}.Check().empty());
  EXPECT_NE(TexelGrid({0, 4, 20.0}).Check().find("texture size"), std::string::npos);
  EXPECT_NE(TexelGrid({4, 4, 0.0}).Check().find("sample_size_mm"), std::string::npos);
  EXPECT_NE(TexelGrid({4, 4, std::numeric_limits<double>::infinity()}).Check().find("sample_size_mm"),
            std::string::npos);
}

}  // namespace
}  // namespace mesocap::calibration
