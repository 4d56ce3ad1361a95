// A capture recorded through the Aravis backend from the simulated cameras
// served as GigE Vision devices equals, byte for byte, the same capture
// recorded from the simulated cameras directly: every frame crosses
// loopback on the real GVSP protocol without a bit changing. Runs in a
// network namespace of its own (scripts/in-network-namespace.sh), where the
// tiny rig's two cameras get 127.0.0.1 and 127.0.0.2.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <thread>

#include "tests/common/mesocap_command.h"
#include "tests/common/no_leftovers.h"
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
  const auto served =
      testing::Mesocap("simulate --rig " + rig + " --seed 4 --serve-cameras --out " + (dir / "b" / "S").string(),
                       "mkdir -p " + (dir / "b").string() + " &&");
  ASSERT_EQ(served.exit_code, 0) << served.err;
  EXPECT_NE(served.err.find("serving camera cam1 as a GigE Vision device at 127.0.0.2"), std::string::npos)
      << served.err;
  EXPECT_NE(served.err.find("(0 dropped"), std::string::npos) << served.err;
  EXPECT_EQ(testing::Differences(testing::Normalized(dir / "a" / "S"), testing::Normalized(dir / "b" / "S")), "");
}

// `mesocap sim serve-cameras` in the background, stopped by SIGTERM.
class ServeCameras {
 public:
  explicit ServeCameras(const std::filesystem::path& log) {
    pid_ = ::fork();
    if (pid_ == 0) {
      if (std::freopen(log.c_str(), "w", stderr) == nullptr) ::_exit(126);
      ::execl(MESOCAP_BINARY, MESOCAP_BINARY, "sim", "serve-cameras", "--rig", "tiny", nullptr);
      ::_exit(127);
    }
    for (int i = 0; i < 200 && testing::Slurp(log).find("serving 2 cameras") == std::string::npos; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  // The exit status after SIGTERM.
  int Stop() {
    ::kill(pid_, SIGTERM);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }
  ~ServeCameras() {
    if (pid_ > 0) Stop();
  }

 private:
  pid_t pid_ = -1;
};

TEST(ServedCameras, AnyGenICamClientConnectsAndDevicesListsThem) {
  testing::TemporaryDirectory dir;
  ServeCameras server(dir / "serve.log");
  // Aravis' own command-line client reads the served camera's features.
  const int status = std::system(
      ("arv-tool-0.8 -a 127.0.0.2 control Width PixelFormat > " + (dir / "tool.out").string() + " 2>&1").c_str());
  EXPECT_EQ(WEXITSTATUS(status), 0);
  const std::string features = testing::Slurp(dir / "tool.out");
  EXPECT_NE(features.find("Width = 128"), std::string::npos) << features;
  EXPECT_NE(features.find("PixelFormat = RGB12"), std::string::npos) << features;

  const auto devices = testing::Mesocap("devices");
  EXPECT_EQ(devices.exit_code, 0) << devices.err;
  EXPECT_NE(devices.out.find("cam0"), std::string::npos) << devices.out;
  EXPECT_NE(devices.out.find("GigEVision 127.0.0.2"), std::string::npos) << devices.out;

  // The preflight: the served camera opens; the Tic and the GPIO chip this
  // machine lacks are named, and the exit status says so.
  nlohmann::json rig = testing::OneSweepRig();
  rig["cameras"][1]["backend"] = "aravis";
  rig["cameras"][1]["device"] = "cam1";  // by serial
  rig["turntable"].update({{"backend", "tic"}, {"serial", "00123456"}});
  const auto ok = testing::Mesocap("rig check " + testing::WriteRig(dir / "rig.json", rig));
  EXPECT_EQ(ok.exit_code, 1);
  EXPECT_NE(ok.out.find("camera cam1  aravis cam1                  ok: Aravis Fake, 128 x 96, 12 bits, 3 channels"),
            std::string::npos)
      << ok.out;
  EXPECT_NE(ok.out.find("turntable    tic 00123456                 FAILED: no Tic with serial 00123456 found"),
            std::string::npos)
      << ok.out;
  EXPECT_NE(ok.err.find("1 of 6 devices failed"), std::string::npos) << ok.err;
  EXPECT_EQ(server.Stop(), 0);
  EXPECT_NE(testing::Slurp(dir / "serve.log").find("frames served"), std::string::npos);
}

// No process or socket outlives the tests (tests/common/no_leftovers.h).
::testing::Environment* const kNoLeftovers = ::testing::AddGlobalTestEnvironment(new ::mesocap::testing::NoLeftovers);

}  // namespace
}  // namespace mesocap
