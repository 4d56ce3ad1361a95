// The cameras' calibration from photos of a board, against the truth the
// photos were rendered with (tests/common/board_photos.h).
#include "calibration/camera_calibration.h"

#include <gtest/gtest.h>

#include "tests/common/board_photos.h"

namespace mesocap::calibration {
namespace {

const CalibrationBoard kCharuco = ParseBoardSpec("charuco:8x6:20:15:DICT_5X5_100");
const CalibrationBoard kChessboard = ParseBoardSpec("chessboard:9x6:18");

TEST(BoardCornerDetector, FindsChArUcoCornersToATenthOfAPixel) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration camera = testing::TestCamera("cam0");
  testing::DetectorError floor;
  const CameraViews views = testing::Photograph(print, camera, testing::BoardPoses(kCharuco, 6, 400, 0.5, 1), 100, &floor);
  for (const BoardDetection& d : views.detections) EXPECT_GE(d.size(), 20u);
  EXPECT_GT(floor.corners, 150);
  EXPECT_LT(floor.rms_px, 0.1);
  for (const DetectionQuality& q : views.qualities) {
    EXPECT_LT(q.edge_width_px, 2.0);
    EXPECT_EQ(q.saturated_fraction, 0.0);
  }
}

TEST(CameraCalibration, OneCameraFromChArUcoPhotos) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration truth = testing::TestCamera("cam0");
  testing::DetectorError floor;
  const CameraViews views = testing::Photograph(print, truth, testing::BoardPoses(kCharuco, 12, 400, 0.6, 2), 200, &floor);
  const CameraCalibrationResult result = CalibrateCameras(kCharuco, {views}, {});
  ASSERT_EQ(result.cameras.size(), 1u);
  const CalibratedCamera& c = result.cameras[0];
  const formats::Intrinsics& k = c.calibration.intrinsics;
  std::printf("floor %.4f rms %.4f fx %.3f+-%.3f fy %.3f cx %.3f+-%.3f cy %.3f k1 %.4f proj %.3f\n", floor.rms_px,
              c.rms_px, k.fx, *k.uncertainty.fx, k.fy, k.cx, *k.uncertainty.cx, k.cy, c.calibration.distortion.k1,
              c.projection_uncertainty_px);
  EXPECT_EQ(c.images_used, 12);
  EXPECT_LT(c.rms_px, 1.2 * floor.rms_px);
  EXPECT_NEAR(k.fx, truth.intrinsics.fx, 4 * *k.uncertainty.fx + 1e-3);
  EXPECT_NEAR(k.cx, truth.intrinsics.cx, 4 * *k.uncertainty.cx + 1e-3);
}

}  // namespace
}  // namespace mesocap::calibration
