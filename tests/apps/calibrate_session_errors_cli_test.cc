// `mesocap calibrate --session` refusing what is not a calibration session,
// and `calibrate` without what it needs, writing nothing.
#include <gtest/gtest.h>

#include <filesystem>

#include "tests/common/mesocap_command.h"

namespace mesocap {
namespace {

using testing::Mesocap;
using testing::TemporaryDirectory;

TEST(CalibrateSessionCli, ACaptureSessionIsNotACalibrationSession) {
  TemporaryDirectory scratch;
  const auto sim = Mesocap("simulate --rig tiny --scene weave --plan btf --out " + (scratch / "capture").string());
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const auto r = Mesocap("calibrate --session " + (scratch / "capture").string() + " --out " +
                         (scratch / "c.json").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("has no board images"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(scratch / "c.json"));
}

TEST(CalibrateSessionCli, CalibrateWithoutSessionOrSubcommandSaysWhatItNeeds) {
  const auto r = Mesocap("calibrate");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--session"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace mesocap
