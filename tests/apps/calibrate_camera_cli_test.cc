// `mesocap calibrate camera` as a user runs it: folders of PNG photos of a
// ChArUco board from two cameras with known intrinsics and relative pose
// (rendered with exact truth, tests/common/board_photos.h), and bad input.
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/image_io.h"
#include "formats/calibration.h"
#include "tests/common/board_photos.h"
#include "tests/common/mesocap_command.h"

namespace mesocap {
namespace {

using testing::Mesocap;
using testing::TemporaryDirectory;

constexpr const char* kBoard = "charuco:8x6:20:15:DICT_5X5_100";

formats::CameraCalibration SecondCamera() {
  formats::CameraCalibration camera = testing::TestCamera("right", -0.05);
  camera.intrinsics.fx = 760;
  camera.intrinsics.fy = 760;
  camera.intrinsics.cx = 316;
  camera.intrinsics.cy = 244;
  // 100 mm to the side, turned to look at the board 400 mm ahead.
  camera.pose.transform.rotation = Eigen::AngleAxisd(-0.245, Eigen::Vector3d::UnitY()).toRotationMatrix();
  camera.pose.transform.translation = Eigen::Vector3d(100, 0, 0);
  return camera;
}

class CalibrateCameraCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    folder_ = new TemporaryDirectory;
    const calibration::CalibrationBoard board = calibration::ParseBoardSpec(kBoard);
    const calibration::BoardPrint print(board);
    const std::vector<core::RigidTransform> poses = testing::BoardPoses(board, 12, 400, 0.5, 7);
    const formats::CameraCalibration cameras[2] = {testing::TestCamera("left"), SecondCamera()};
    for (int c = 0; c < 2; ++c) {
      std::filesystem::create_directories(Folder(c));
      for (std::size_t i = 0; i < poses.size(); ++i) {
        core::WriteImage(Folder(c) / ("shot" + std::to_string(10 + i) + ".png"),
                         testing::BoardPhoto(print, poses[i], cameras[c], 1000 * c + i), core::PixelEncoding::kUInt16);
      }
    }
  }
  static void TearDownTestSuite() {
    if (std::getenv("KEEP"))
      std::filesystem::copy(folder_->path(), std::getenv("KEEP"), std::filesystem::copy_options::recursive);
    delete folder_;
  }
  static std::filesystem::path Folder(int camera) { return *folder_ / (camera == 0 ? "left" : "right"); }
  static TemporaryDirectory* folder_;
};
TemporaryDirectory* CalibrateCameraCli::folder_ = nullptr;

TEST_F(CalibrateCameraCli, TwoCamerasJointlyWithTheirRelativePose) {
  TemporaryDirectory out;
  const auto r = Mesocap("calibrate camera --images " + Folder(0).string() + " --images " + Folder(1).string() +
                         " --board " + kBoard + " --out " + (out / "calibration.json").string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  ASSERT_EQ(report["cameras"].size(), 2u);
  const formats::CameraCalibration truth[2] = {testing::TestCamera("left"), SecondCamera()};
  int chosen_rungs = 0;
  for (int c = 0; c < 2; ++c) {
    const nlohmann::json& camera = report["cameras"][static_cast<std::size_t>(c)];
    EXPECT_EQ(camera["id"], c == 0 ? "left" : "right");
    EXPECT_EQ(camera["images_used"], 12);
    EXPECT_LT(camera["rms_px"].get<double>(), 0.15);
    // Within 4 sigma of the truth, and the sigmas small.
    for (const char* name : {"fx", "fy", "cx", "cy"}) {
      const double expected = name[0] == 'f' ? (name[1] == 'x' ? truth[c].intrinsics.fx : truth[c].intrinsics.fy)
                                             : (name[1] == 'x' ? truth[c].intrinsics.cx : truth[c].intrinsics.cy);
      const double sigma = camera["std"][name].get<double>();
      EXPECT_NEAR(camera[name].get<double>(), expected, 4 * sigma) << name << " of camera " << c;
      EXPECT_LT(sigma, 2.0) << name;
    }
    EXPECT_NEAR(camera["k1"].get<double>(), truth[c].distortion.k1, 4 * camera["std"]["k1"].get<double>() + 1e-4);
    // The distortion terms as the ladder chose them: those left out are 0
    // with sigma 0; an estimated one whose sigma exceeds it is listed.
    int terms = 0;
    for (const nlohmann::json& rung : camera["distortion_ladder"]) {
      if (rung["chosen"].get<bool>()) terms = rung["terms"].get<int>(), ++chosen_rungs;
    }
    const char* distortion_names[5] = {"k1", "k2", "p1", "p2", "k3"};
    for (int i = 0; i < 5; ++i) {
      const double value = camera[distortion_names[i]].get<double>();
      const double sigma = camera["std"][distortion_names[i]].get<double>();
      const nlohmann::json& undetermined = camera["undetermined_terms"];
      const bool listed =
          std::find(undetermined.begin(), undetermined.end(), distortion_names[i]) != undetermined.end();
      if (i >= terms) {
        EXPECT_EQ(value, 0.0) << distortion_names[i];
        EXPECT_EQ(sigma, 0.0) << distortion_names[i];
      } else {
        EXPECT_EQ(listed, sigma > std::abs(value)) << distortion_names[i];
      }
    }
    EXPECT_GT(camera["projection_uncertainty_px"].get<double>(), 0);
    EXPECT_LT(camera["projection_uncertainty_px"].get<double>(), 2.0);
    EXPECT_TRUE(camera["cross_validation_px"].is_number());
    EXPECT_LT(camera["cross_validation_px"].get<double>(), 3.0);
  }
  EXPECT_EQ(chosen_rungs, 2) << "one model chosen per camera";
  ASSERT_EQ(report["relative_poses"].size(), 1u);
  const nlohmann::json& pose = report["relative_poses"][0];
  EXPECT_EQ(pose["from"], "left");
  EXPECT_EQ(pose["to"], "right");
  // The rotation about y and the translation, within 4 sigma of the truth.
  EXPECT_NEAR(pose["rotation_deg"][1].get<double>(), -0.245 * 180 / 3.14159265358979,
              4 * pose["std"]["rotation_deg"][1].get<double>());
  EXPECT_NEAR(pose["translation_mm"][0].get<double>(), 100.0, 4 * pose["std"]["translation_mm"][0].get<double>());
  EXPECT_NEAR(pose["translation_mm"][2].get<double>(), 0.0, 4 * pose["std"]["translation_mm"][2].get<double>());
  EXPECT_LT(pose["std"]["translation_mm"][0].get<double>(), 1.0);

  const formats::Calibration written = formats::ReadCalibration(out / "calibration.json");
  ASSERT_EQ(written.cameras.size(), 2u);
  EXPECT_TRUE(written.cameras[0].intrinsics.uncertainty.fx.has_value());
  EXPECT_TRUE(written.cameras[1].pose.uncertainty.translation_mm.has_value());
  EXPECT_NEAR(written.cameras[1].pose.transform.translation.x(), 100.0, 1.0);
}

// The left camera's photos as a camera writes them: 8-bit JPEG, some
// progressive, and some taken with the camera on its side (stored turned by
// 90 degrees, EXIF orientation 6 says to turn them back). Read upright, they
// give the camera's intrinsics within 4 sigma.
TEST_F(CalibrateCameraCli, JpegPhotosWithExifOrientationAreCalibrated) {
  TemporaryDirectory scratch;
  std::filesystem::create_directories(scratch / "jpeg");
  int index = 0;
  for (const auto& entry : std::filesystem::directory_iterator(Folder(0))) {
    const core::Image photo = core::ReadImage(entry.path());
    OIIO::ImageBuf upright(OIIO::ImageSpec(photo.width(), photo.height(), photo.channels(), OIIO::TypeDesc::FLOAT),
                           const_cast<float*>(photo.data()));
    const bool on_its_side = index % 3 == 0;
    // EXIF 6 displays the stored image turned 90 degrees clockwise: store it turned counter-clockwise.
    OIIO::ImageBuf stored = on_its_side ? OIIO::ImageBufAlgo::rotate270(upright) : upright;
    stored.specmod().attribute("Orientation", on_its_side ? 6 : 1);
    stored.specmod().attribute("jpeg:progressive", index % 2);
    stored.specmod().attribute("Compression", "jpeg:95");
    const std::filesystem::path file = scratch / "jpeg" / entry.path().filename().replace_extension(".jpg");
    ASSERT_TRUE(stored.write(file.string(), OIIO::TypeDesc::UINT8)) << stored.geterror();
    ++index;
  }
  const auto r = Mesocap("calibrate camera --images " + (scratch / "jpeg").string() + " --board " + kBoard + " --out " +
                         (scratch / "c.json").string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json camera = nlohmann::json::parse(r.out)["cameras"][0];
  const formats::CameraCalibration truth = testing::TestCamera("left");
  EXPECT_EQ(camera["images_used"], 12);
  EXPECT_EQ(camera["width"], 640);
  const double expected[4] = {truth.intrinsics.fx, truth.intrinsics.fy, truth.intrinsics.cx, truth.intrinsics.cy};
  const char* names[4] = {"fx", "fy", "cx", "cy"};
  for (int i = 0; i < 4; ++i) {
    EXPECT_NEAR(camera[names[i]].get<double>(), expected[i], 4 * camera["std"][names[i]].get<double>()) << names[i];
  }
}

TEST_F(CalibrateCameraCli, PrintsATableWithoutJson) {
  TemporaryDirectory out;
  const auto r = Mesocap("calibrate camera --images " + Folder(0).string() + " --board " + kBoard + " --out " +
                         (out / "c.json").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("left"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("fx px"), std::string::npos) << r.out;
}

TEST_F(CalibrateCameraCli, BadInputNamesTheFileOrFlagAndWritesNothing) {
  TemporaryDirectory scratch;
  const std::filesystem::path out = scratch / "calibration.json";
  const std::string tail = " --out " + out.string();
  std::filesystem::create_directories(scratch / "empty");
  std::filesystem::create_directories(scratch / "broken");
  std::filesystem::copy(Folder(0), scratch / "broken", std::filesystem::copy_options::recursive);
  std::ofstream(scratch / "broken" / "shot99.png") << "not a png";
  std::filesystem::create_directories(scratch / "mixed");
  std::filesystem::copy(Folder(0), scratch / "mixed", std::filesystem::copy_options::recursive);
  core::WriteImage(scratch / "mixed" / "shot99.png", core::Image(320, 240, 1, 0.5f), core::PixelEncoding::kUInt16);

  struct Case {
    std::string args, expected;
  };
  const std::vector<Case> cases = {
      {"--images " + (scratch / "empty").string() + " --board " + kBoard, "holds no JPEG, PNG or TIFF photo"},
      {"--images " + (scratch / "missing").string() + " --board " + kBoard, "not a folder"},
      {"--images " + (scratch / "broken").string() + " --board " + kBoard, "shot99.png"},
      {"--images " + (scratch / "mixed").string() + " --board " + kBoard, "differs from the folder's first photo"},
      {"--images " + (scratch / "mixed").string() + " --board " + kBoard, "shot99.png: field 'size': 320x240"},
      {"--images " + (scratch / "mixed").string() + " --board " + kBoard, "shot10.png"},
      {"--images " + Folder(0).string() + " --board charuco:8x6:20", "expected chessboard:COLSxROWS:SQUARE_MM"},
      {"--images " + Folder(0).string() + " --board charuco:8y6:20:15:DICT_5X5_100", "is not COLSxROWS"},
      {"--images " + Folder(0).string() + " --board charuco:8x6:20:25:DICT_5X5_100", "smaller than the square"},
      {"--images " + Folder(0).string() + " --board charuco:8x6:20:15:DICT_9X9_1", "unknown ArUco dictionary"},
      {"--images " + Folder(0).string() + " --board chessboard:9x6:-3", "SQUARE_MM"},
  };
  for (const Case& c : cases) {
    const auto r = Mesocap("calibrate camera " + c.args + tail);
    EXPECT_NE(r.exit_code, 0) << c.args;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << "\n" << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << c.args;
  }
}

TEST_F(CalibrateCameraCli, ABoardThatDoesNotFitThePhotosIsRefusedNamingTheResidual) {
  TemporaryDirectory scratch;
  const auto r = Mesocap("calibrate camera --images " + Folder(0).string() +
                         " --board charuco:7x6:20:15:DICT_5X5_100 --out " + (scratch / "c.json").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("does not fit the photos"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("reprojection RMS"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(scratch / "c.json"));
}

TEST_F(CalibrateCameraCli, AnExistingCalibrationIsReplacedOnlyWithReplace) {
  TemporaryDirectory scratch;
  std::ofstream(scratch / "c.json") << "{}";
  const std::string args = "calibrate camera --images " + Folder(0).string() + " --board " + kBoard + " --out " +
                           (scratch / "c.json").string();
  const auto refused = Mesocap(args);
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_EQ(testing::Slurp(scratch / "c.json"), "{}");
  // --replace replaces a calibration, not any file: "{}" is none.
  const auto not_one = Mesocap(args + " --replace");
  EXPECT_EQ(not_one.err, "mesocap: error: " + (scratch / "c.json").string() +
                             ": --replace replaces only a calibration file, and this is not one; move it away or "
                             "choose another output\n");
  EXPECT_EQ(testing::Slurp(scratch / "c.json"), "{}");
  std::filesystem::remove(scratch / "c.json");
  ASSERT_EQ(Mesocap(args).exit_code, 0);
  const auto replaced = Mesocap(args + " --replace");
  EXPECT_EQ(replaced.exit_code, 0) << replaced.err;
  EXPECT_NO_THROW(formats::ReadCalibration(scratch / "c.json"));
}

}  // namespace
}  // namespace mesocap
