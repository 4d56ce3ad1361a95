// `mesocap calibrate --session` refusing what is not a calibration session,
// and `calibrate` without what it needs, writing nothing.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "tests/common/mesocap_command.h"

namespace mesocap {
namespace {

using testing::Mesocap;
using testing::TemporaryDirectory;

TEST(CalibrateSessionCli, ACaptureSessionIsNotACalibrationSession) {
  TemporaryDirectory scratch;
  const auto sim = Mesocap("simulate --rig tiny --scene weave --plan btf --out " + (scratch / "capture").string());
  ASSERT_EQ(sim.exit_code, 0) << sim.err;
  const auto r =
      Mesocap("calibrate --session " + (scratch / "capture").string() + " --out " + (scratch / "c.json").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("has no board images"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(scratch / "c.json"));
}

TEST(CalibrateSessionCli, CalibrateWithoutSessionOrSubcommandSaysWhatItNeeds) {
  const auto r = Mesocap("calibrate");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--session"), std::string::npos) << r.err;
}

// The limits on the fits' sigmas are checked before the session is read.
TEST(CalibrateSessionCli, ANonPositiveSigmaLimitIsNamed) {
  TemporaryDirectory scratch;
  for (const std::string flag : {"--max-lamp-sigma-mm", "--max-mount-axis-sigma-deg"}) {
    const auto r = Mesocap("calibrate --session " + (scratch / "none").string() + " --out " +
                           (scratch / "c.json").string() + " " + flag + " 0");
    EXPECT_NE(r.exit_code, 0) << flag;
    EXPECT_NE(r.err.find(flag + ": expected a positive number"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(scratch / "c.json"));
  }
}

}  // namespace
}  // namespace mesocap
