// The calibration's uncertainty against the truth over many seeded
// calibrations (label `accuracy`: about a minute and a half in release).
#include <gtest/gtest.h>

#include "calibration/camera_calibration.h"
#include "tests/common/board_photos.h"

namespace mesocap::calibration {
namespace {

const CalibrationBoard kCharuco = ParseBoardSpec("charuco:8x6:20:15:DICT_5X5_100");

// Over seeded calibrations, the errors against the truth divided by the
// reported sigmas: RMS near 1 when the uncertainty is honest.
TEST(CameraCalibrationUncertainty, ErrorsOverSigmasHaveRmsNearOne) {
  const BoardPrint print(kCharuco);
  const formats::CameraCalibration truth = testing::TestCamera("cam0");
  std::vector<double> ratios[4];
  for (std::uint64_t seed = 0; seed < 20; ++seed) {
    const CameraViews views =
        testing::Photograph(print, truth, testing::BoardPoses(kCharuco, 12, 400, 0.6, 50 + seed), 10000 * (seed + 1));
    const CameraCalibrationResult result = CalibrateCameras(kCharuco, {views}, {});
    const formats::Intrinsics& k = result.cameras[0].calibration.intrinsics;
    ratios[0].push_back((k.fx - truth.intrinsics.fx) / *k.uncertainty.fx);
    ratios[1].push_back((k.fy - truth.intrinsics.fy) / *k.uncertainty.fy);
    ratios[2].push_back((k.cx - truth.intrinsics.cx) / *k.uncertainty.cx);
    ratios[3].push_back((k.cy - truth.intrinsics.cy) / *k.uncertainty.cy);
    std::printf("seed %2d fx %+.3f (%.3f) cx %+.3f (%.3f) rms %.3f\n", static_cast<int>(seed),
                k.fx - truth.intrinsics.fx, *k.uncertainty.fx, k.cx - truth.intrinsics.cx, *k.uncertainty.cx,
                result.cameras[0].rms_px);
  }
  const char* names[4] = {"fx", "fy", "cx", "cy"};
  for (int p = 0; p < 4; ++p) {
    double sum = 0;
    for (const double r : ratios[p]) sum += r * r;
    const double rms = std::sqrt(sum / ratios[p].size());
    std::printf("%s: RMS of error / sigma %.3f\n", names[p], rms);
    EXPECT_GT(rms, 0.6) << names[p];
    EXPECT_LT(rms, 1.6) << names[p];
  }
}

}  // namespace
}  // namespace mesocap::calibration
