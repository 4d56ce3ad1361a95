// The cameras' calibration from photos of a board, against the truth the
// photos were rendered with (tests/common/board_photos.h).
#include "calibration/camera_calibration.h"

#include <gtest/gtest.h>

#include "calibration/board_corner_detector.h"
#include "tests/common/board_photos.h"

namespace mesocap::calibration {
namespace {

const CalibrationBoard kCharuco = ParseBoardSpec("charuco:8x6:20:15:DICT_5X5_100");
const CalibrationBoard kChessboard = ParseBoardSpec("chessboard:9x6:18");

// Detected corners against their true positions: the detector's own error.
struct DetectorError {
  double rms_px = 0;
  int corners = 0;
};

DetectorError Compare(const BoardDetection& detection, const std::vector<Eigen::Vector2d>& truth) {
  DetectorError error;
  double sum = 0;
  for (std::size_t i = 0; i < detection.size(); ++i) {
    sum += (detection.pixels[i] - truth[static_cast<std::size_t>(detection.ids[i])]).squaredNorm();
    ++error.corners;
  }
  error.rms_px = std::sqrt(sum / std::max(1, error.corners));
  return error;
}

CameraViews Photograph(const BoardPrint& print, const formats::CameraCalibration& camera,
                       const std::vector<core::RigidTransform>& poses, std::uint64_t seed,
                       DetectorError* floor = nullptr) {
  const BoardCornerDetector detector(print.board());
  CameraViews views;
  views.id = camera.id;
  views.width = camera.width;
  views.height = camera.height;
  double sum = 0;
  int corners = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const core::Image photo = test::BoardPhoto(print, poses[i], camera, seed + i);
    views.names.push_back("photo" + std::to_string(i) + ".png");
    views.detections.push_back(detector.Detect(photo));
    views.qualities.push_back(detector.Quality(photo, views.detections.back()));
    const DetectorError e = Compare(views.detections.back(), sim::TrueCornerPixels(print.board(), poses[i], camera));
    sum += e.rms_px * e.rms_px * e.corners;
    corners += e.corners;
  }
  if (floor) *floor = {std::sqrt(sum / std::max(1, corners)), corners};
  return views;
}

TEST(BoardCornerDetector, FindsChArUcoCornersToATenthOfAPixel) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration camera = test::TestCamera("cam0");
  DetectorError floor;
  const CameraViews views = Photograph(print, camera, test::BoardPoses(kCharuco, 6, 400, 0.5, 1), 100, &floor);
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
  const formats::CameraCalibration truth = test::TestCamera("cam0");
  DetectorError floor;
  const CameraViews views = Photograph(print, truth, test::BoardPoses(kCharuco, 12, 400, 0.6, 2), 200, &floor);
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
