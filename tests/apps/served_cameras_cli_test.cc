// A capture recorded through the Aravis backend from the simulated cameras
// served as GigE Vision devices equals, byte for byte, the same capture
// recorded from the simulated cameras directly: every frame crosses
// loopback on the real GVSP protocol without a bit changing. Runs in a
// network namespace of its own (scripts/in-network-namespace.sh), where the
// tiny rig's two cameras get 127.0.0.1 and 127.0.0.2.
#include <gtest/gtest.h>

#include "tests/common/mesocap_command.h"
#include "tests/common/normalized_tree.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

TEST(ServedCameras, SessionThroughGigEVisionIsByteIdentical) {
  testing::TemporaryDirectory dir;
  const std::string rig = testing::WriteRig(dir / "rig.json");
  // The same folder name for both: a session's files do not name it, but keep it certain.
  const auto direct = testing::Mesocap("-q simulate --rig " + rig + " --seed 4 --out " + (dir / "a" / "S").string(),
                                       "mkdir -p " + (dir / "a").string() + " &&");
  ASSERT_EQ(direct.exit_code, 0) << direct.err;
  const auto served = testing::Mesocap(
      "simulate --rig " + rig + " --seed 4 --serve-cameras --out " + (dir / "b" / "S").string(),
      "mkdir -p " + (dir / "b").string() + " &&");
  ASSERT_EQ(served.exit_code, 0) << served.err;
  EXPECT_NE(served.err.find("serving camera cam1 as a GigE Vision device at 127.0.0.2"), std::string::npos)
      << served.err;
  EXPECT_NE(served.err.find("(0 dropped"), std::string::npos) << served.err;
  EXPECT_EQ(testing::Differences(testing::Normalized(dir / "a" / "S"), testing::Normalized(dir / "b" / "S")), "");
}

}  // namespace
}  // namespace mesocap
