// The cameras' calibration from photos of a board, against the truth the
// photos were rendered with (tests/common/board_photos.h).
#include "calibration/camera_calibration.h"

#include <gtest/gtest.h>

#include "calibration/calibration_report.h"

#include <map>

#include <opencv2/imgproc.hpp>

#include "tests/common/board_photos.h"

namespace mesocap::calibration {
namespace {

const CalibrationBoard kCharuco = ParseBoardSpec("charuco:8x6:20:15:DICT_5X5_100");
const CalibrationBoard kChessboard = ParseBoardSpec("chessboard:9x6:18");

TEST(BoardCornerDetector, FindsChArUcoCornersToATenthOfAPixel) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration camera = testing::TestCamera("cam0");
  testing::DetectorError floor;
  const CameraViews views =
      testing::Photograph(print, camera, testing::BoardPoses(kCharuco, 6, 400, 0.5, 1), 100, &floor);
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
  const CameraViews views =
      testing::Photograph(print, truth, testing::BoardPoses(kCharuco, 12, 400, 0.6, 2), 200, &floor);
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

// Each of fx, fy, cx, cy and k1 within `sigmas` reported sigmas of the truth.
void ExpectWithinSigmas(const formats::CameraCalibration& estimate, const formats::CameraCalibration& truth,
                        double sigmas) {
  const formats::Intrinsics& k = estimate.intrinsics;
  EXPECT_NEAR(k.fx, truth.intrinsics.fx, sigmas * *k.uncertainty.fx);
  EXPECT_NEAR(k.fy, truth.intrinsics.fy, sigmas * *k.uncertainty.fy);
  EXPECT_NEAR(k.cx, truth.intrinsics.cx, sigmas * *k.uncertainty.cx);
  EXPECT_NEAR(k.cy, truth.intrinsics.cy, sigmas * *k.uncertainty.cy);
  EXPECT_NEAR(estimate.distortion.k1, truth.distortion.k1, sigmas * *estimate.distortion.uncertainty.k1);
}

// Every view square to the camera: the focal length trades off against the
// board's distance and is poorly observed. The answer must say so (a large
// sigma and a warning), and its error stay within that sigma's reach.
TEST(CameraCalibrationHardCases, FrontoParallelViewsGiveALargeFocalSigmaAndAWarning) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration truth = testing::TestCamera("cam0");
  const CameraViews views = testing::Photograph(print, truth, testing::BoardPoses(kCharuco, 10, 400, 0.02, 3), 300);
  const CameraCalibrationResult result = CalibrateCameras(kCharuco, {views}, {});
  const formats::Intrinsics& k = result.cameras[0].calibration.intrinsics;
  ASSERT_TRUE(k.uncertainty.fx.has_value());
  std::printf("fronto-parallel: fx %.2f +- %.2f (truth %.2f)\n", k.fx, *k.uncertainty.fx, truth.intrinsics.fx);
  EXPECT_GT(*k.uncertainty.fx / k.fx, 0.005);
  EXPECT_NEAR(k.fx, truth.intrinsics.fx, 4 * *k.uncertainty.fx);
  ASSERT_FALSE(result.warnings.empty());
  EXPECT_NE(result.warnings[0].find("focal length poorly observed"), std::string::npos) << result.warnings[0];
}

TEST(CameraCalibrationHardCases, ThreePhotosOnly) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration truth = testing::TestCamera("cam0");
  const CameraViews views = testing::Photograph(print, truth, testing::BoardPoses(kCharuco, 3, 400, 0.6, 4), 400);
  const CameraCalibrationResult result = CalibrateCameras(kCharuco, {views}, {});
  EXPECT_EQ(result.cameras[0].images_used, 3);
  ExpectWithinSigmas(result.cameras[0].calibration, truth, 4);
  std::printf("three photos: fx sigma %.2f px\n", *result.cameras[0].calibration.intrinsics.uncertainty.fx);
}

// The ladder's rule as camera_calibration.h states it, on one camera's figures.
void ExpectLeastBicChosenAndTheRestZero(const CalibratedCamera& camera) {
  ASSERT_EQ(camera.distortion_ladder.size(), 4u);
  const DistortionRung* least = &camera.distortion_ladder[0];
  for (std::size_t r = 0; r < 4; ++r) {
    const DistortionRung& rung = camera.distortion_ladder[r];
    EXPECT_EQ(rung.model, kDistortionLadder[r]);
    if (r > 0) {
      EXPECT_LE(rung.rms_px, camera.distortion_ladder[r - 1].rms_px * (1 + 1e-6)) << "nested models";
    }
    if (rung.aic < least->aic) least = &rung;
  }
  EXPECT_EQ(camera.distortion_model, least->model);
  const formats::Distortion& d = camera.calibration.distortion;
  const double values[5] = {d.k1, d.k2, d.p1, d.p2, d.k3};
  const std::optional<double> sigmas[5] = {d.uncertainty.k1, d.uncertainty.k2, d.uncertainty.p1, d.uncertainty.p2,
                                           d.uncertainty.k3};
  for (int i = TermCount(camera.distortion_model); i < 5; ++i) {
    EXPECT_EQ(values[i], 0.0) << "term " << i << " left out";
    EXPECT_EQ(sigmas[i].value_or(-1), 0.0) << "term " << i << " left out";
  }
}

TEST(CameraCalibrationHardCases, StrongBarrelDistortion) {
  const BoardPrint print(kCharuco);
  formats::CameraCalibration truth = testing::TestCamera("cam0", -0.3);
  truth.distortion.k2 = 0.08;
  testing::DetectorError floor;
  const CameraViews views =
      testing::Photograph(print, truth, testing::BoardPoses(kCharuco, 12, 400, 0.6, 5), 500, &floor);
  const CameraCalibrationResult result = CalibrateCameras(kCharuco, {views}, {});
  ExpectWithinSigmas(result.cameras[0].calibration, truth, 4);
  EXPECT_LT(result.cameras[0].rms_px, 1.2 * floor.rms_px);
  // k1 alone leaves k2's 2 px at the image's corner: the ladder goes higher.
  const DistortionModel model = result.cameras[0].distortion_model;
  std::printf("strong barrel: model %s\n", ToString(model));
  ExpectLeastBicChosenAndTheRestZero(result.cameras[0]);
  EXPECT_TRUE(model == DistortionModel::kK1K2 || model == DistortionModel::kFull) << ToString(model);
  EXPECT_NEAR(result.cameras[0].calibration.distortion.k2, truth.distortion.k2,
              4 * *result.cameras[0].calibration.distortion.uncertainty.k2);
}

// A lens without distortion: the ladder estimates no term the photos cannot
// tell from zero, and the pinhole stays within its sigmas.
TEST(CameraCalibrationHardCases, ADistortionFreeLensGetsNoneOrK1) {
  const BoardPrint print(kCharuco);
  formats::CameraCalibration truth = testing::TestCamera("cam0", 0.0);
  truth.distortion = {};
  const CameraViews views = testing::Photograph(print, truth, testing::BoardPoses(kCharuco, 12, 400, 0.6, 6), 600);
  const CameraCalibrationResult result = CalibrateCameras(kCharuco, {views}, {});
  const CalibratedCamera& camera = result.cameras[0];
  std::printf("distortion-free: model %s, AIC", ToString(camera.distortion_model));
  for (const DistortionRung& rung : camera.distortion_ladder) std::printf(" %.1f", rung.aic);
  std::printf("\n");
  EXPECT_TRUE(camera.distortion_model == DistortionModel::kNone || camera.distortion_model == DistortionModel::kK1)
      << ToString(camera.distortion_model);
  ExpectLeastBicChosenAndTheRestZero(camera);
  const formats::Intrinsics& k = camera.calibration.intrinsics;
  EXPECT_NEAR(k.fx, truth.intrinsics.fx, 4 * *k.uncertainty.fx);
  EXPECT_NEAR(k.cx, truth.intrinsics.cx, 4 * *k.uncertainty.cx);
  EXPECT_NEAR(camera.calibration.distortion.k1, 0.0, 4 * camera.calibration.distortion.uncertainty.k1.value_or(0));
}

// The report prints a term whose sigma exceeds it as undetermined, never as
// a value; a term the model leaves out as fixed.
TEST(CalibrationReport, AnUndeterminedTermIsNotPrintedAsAnEstimate) {
  CalibrationReport report;
  report.board = "charuco:5x4:8:6:DICT_4X4_50";
  CalibratedCamera camera;
  camera.calibration.id = "cam0";
  camera.calibration.intrinsics.fx = 714.0;
  camera.calibration.intrinsics.uncertainty.fx = 18.0;
  camera.calibration.distortion.k1 = -0.4201;
  camera.calibration.distortion.k2 = 30.3002;
  camera.calibration.distortion.uncertainty = {0.13, 70.8, 0.0, 0.0, 0.0};
  camera.distortion_model = DistortionModel::kK1K2;
  camera.undetermined_terms = {"k2"};
  for (const DistortionModel model : kDistortionLadder) camera.distortion_ladder.push_back({model, 0.15, 700.0});
  report.cameras.cameras.push_back(camera);
  const std::string table = FormatCalibrationReport(report);
  EXPECT_EQ(table.find("30.3"), std::string::npos) << table;
  EXPECT_NE(table.find("undet."), std::string::npos) << table;
  EXPECT_NE(table.find("k2 undetermined"), std::string::npos) << table;
  EXPECT_NE(table.find("-0.4201"), std::string::npos) << table;
  EXPECT_NE(table.find("cam0 distortion: k1 k2 (ladder:"), std::string::npos) << table;
  const nlohmann::json json = ToJson(report)["cameras"][0];
  EXPECT_EQ(json["distortion_model"], "k1 k2");
  EXPECT_EQ(json["undetermined_terms"], nlohmann::json::array({"k2"}));
  ASSERT_EQ(json["distortion_ladder"].size(), 4u);
  EXPECT_TRUE(json["distortion_ladder"][2]["chosen"].get<bool>());
  EXPECT_FALSE(json["distortion_ladder"][3]["chosen"].get<bool>());

  report.cameras.cameras[0].distortion_model = DistortionModel::kK1;
  report.cameras.cameras[0].undetermined_terms.clear();
  EXPECT_NE(FormatCalibrationReport(report).find("0 (fixed)"), std::string::npos);
}

// A model given, not chosen: the terms it leaves out are zero, not estimated.
TEST(CameraCalibration, AGivenDistortionModelHoldsTheOtherTermsAtZero) {
  const BoardPrint print(kCharuco);
  formats::CameraCalibration truth = testing::TestCamera("cam0", -0.1);
  truth.distortion = {};
  truth.distortion.k1 = -0.1;
  const CameraViews views = testing::Photograph(print, truth, testing::BoardPoses(kCharuco, 8, 400, 0.6, 7), 700);
  CameraCalibrationOptions options;
  options.distortion_models = {DistortionModel::kK1};
  const CalibratedCamera camera = CalibrateCameras(kCharuco, {views}, options).cameras[0];
  EXPECT_EQ(camera.distortion_model, DistortionModel::kK1);
  EXPECT_TRUE(camera.distortion_ladder.empty());
  const formats::Distortion& d = camera.calibration.distortion;
  EXPECT_NEAR(d.k1, -0.1, 4 * *d.uncertainty.k1);
  EXPECT_GT(*d.uncertainty.k1, 0.0);
  for (const double v : {d.k2, d.p1, d.p2, d.k3}) EXPECT_EQ(v, 0.0);
  EXPECT_EQ(*d.uncertainty.k2, 0.0);
  EXPECT_EQ(*d.uncertainty.k3, 0.0);
}

// A ChArUco board half hidden (an object over it) in every other photo: the
// markers' ids still place the visible corners.
TEST(CameraCalibrationHardCases, HalfOccludedChArUcoBoard) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration truth = testing::TestCamera("cam0");
  const std::vector<core::RigidTransform> poses = testing::BoardPoses(kCharuco, 12, 400, 0.6, 6);
  const BoardCornerDetector detector(kCharuco);
  CameraViews views;
  views.id = "cam0";
  views.width = truth.width;
  views.height = truth.height;
  int partial = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    core::Image photo = testing::BoardPhoto(print, poses[i], truth, 600 + i);
    if (i % 2 == 0) {
      // Cover the board's right half: everything right of its projected centre.
      const Eigen::Vector3d centre = poses[i].Apply(Eigen::Vector3d(80, 60, 0));
      const double u = truth.intrinsics.fx * centre.x() / centre.z() + truth.intrinsics.cx;
      for (int y = 0; y < photo.height(); ++y) {
        for (int x = std::max(0, static_cast<int>(u)); x < photo.width(); ++x) photo.at(x, y) = 0.3f;
      }
    }
    views.names.push_back("photo" + std::to_string(i));
    views.detections.push_back(detector.Detect(photo));
    views.qualities.push_back(detector.Quality(photo, views.detections.back()));
    if (i % 2 == 0 && !views.detections.back().empty()) {
      EXPECT_LT(views.detections.back().size(), 25u);
      ++partial;
    }
  }
  EXPECT_GE(partial, 4);
  const CameraCalibrationResult result = CalibrateCameras(kCharuco, {views}, {});
  EXPECT_EQ(result.cameras[0].images_used + static_cast<int>(result.cameras[0].unused_images.size()), 12);
  ExpectWithinSigmas(result.cameras[0].calibration, truth, 4);
}

TEST(CameraCalibrationHardCases, ACameraThatNeverSeesTheBoardIsNamed) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration left = testing::TestCamera("left");
  formats::CameraCalibration away = testing::TestCamera("away");
  away.pose.transform.rotation = Eigen::AngleAxisd(3.14159, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const std::vector<core::RigidTransform> poses = testing::BoardPoses(kCharuco, 4, 400, 0.5, 8);
  const std::vector<CameraViews> views = {testing::Photograph(print, left, poses, 800),
                                          testing::Photograph(print, away, poses, 900)};
  try {
    CalibrateCameras(kCharuco, views, {});
    FAIL() << "expected an error";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera \"away\" never sees the board"), std::string::npos) << e.what();
  }
}

// A blurred and a saturated photo among good ones are set aside, each with
// its reason, and the calibration is as good as without them.
TEST(CameraCalibrationHardCases, BlurredAndSaturatedPhotosAreReportedAsOutliers) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration truth = testing::TestCamera("cam0");
  const std::vector<core::RigidTransform> poses = testing::BoardPoses(kCharuco, 12, 400, 0.6, 9);
  CameraViews views = testing::Photograph(print, truth, poses, 1000);
  const BoardCornerDetector detector(kCharuco);
  {
    core::Image blurred = testing::BoardPhoto(print, poses[3], truth, 1003);
    cv::Mat mat(blurred.height(), blurred.width(), CV_32F, blurred.data());
    cv::GaussianBlur(mat, mat, cv::Size(0, 0), 1.8);
    views.detections[3] = detector.Detect(blurred);
    views.qualities[3] = detector.Quality(blurred, views.detections[3]);
  }
  {
    sim::BoardPhotoOptions bright;
    bright.white_signal = 4.0;  // overexposed: white clips, and so do the blacks' edges
    const core::Image saturated = testing::BoardPhoto(print, poses[7], truth, 1007, bright);
    views.detections[7] = detector.Detect(saturated);
    views.qualities[7] = detector.Quality(saturated, views.detections[7]);
  }
  const CameraCalibrationResult result = CalibrateCameras(kCharuco, {views}, {});
  const CalibratedCamera& camera = result.cameras[0];
  std::map<std::string, std::string> outliers;
  for (const SetAsideImage& image : camera.outlier_images) outliers[image.name] = image.reason;
  ASSERT_TRUE(outliers.count("photo3.png")) << "the blurred photo";
  EXPECT_NE(outliers["photo3.png"].find("blurred"), std::string::npos) << outliers["photo3.png"];
  ASSERT_TRUE(outliers.count("photo7.png")) << "the saturated photo";
  EXPECT_NE(outliers["photo7.png"].find("saturated"), std::string::npos) << outliers["photo7.png"];
  EXPECT_EQ(camera.images_used, 10);
  ExpectWithinSigmas(camera.calibration, truth, 4);
}

}  // namespace
}  // namespace mesocap::calibration
