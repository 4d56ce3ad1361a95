// 20 faults injected into captures the daemon runs on the simulated rig with
// its cameras served over GigE Vision: 5 camera servers killed and started
// again, 5 stages stalled past the runner's retries, 5 lamps burnt out and
// replaced, 5 disks full and cleaned. Each pauses its job with a reason that
// names the fault, the job resumes once the fault is cleared, and it ends
// with the session an undisturbed run records, its frames counted once.
// Runs in network and mount namespaces of its own
// (scripts/in-network-namespace.sh): the served cameras take loopback
// addresses, the full disks are small tmpfs mounts. MESOCAP_FAULTS_RIG=small
// runs them on the small rig (cut to one light-arc angle and one laser
// location) instead of the tiny one cut to one sweep of 8 frames.
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "acquisition/capture_daemon.h"
#include "pipelines/simulated_station.h"
#include "tests/common/normalized_tree.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class DaemonFaultsTest : public ::testing::TestWithParam<int> {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TemporaryDirectory();
    const char* shipped = std::getenv("MESOCAP_FAULTS_RIG");
    nlohmann::json rig =
        shipped && std::string(shipped) != "tiny" ? testing::OnePositionRig(shipped) : testing::OneSweepRig();
    // Three turntable angles: each lamp is switched on three times.
    rig["turntable"]["angles_deg"] = {0.0, 120.0, 240.0};
    rig_ = testing::WriteRig(*dir_ / "rig.json", rig);
    pipelines::SimulatedStation station(StationOptions());
    CaptureRunnerOptions run;
    run.show_progress = false;
    station.OpenSession(*dir_ / "capture", "capture");
    const CaptureRunReport report = station.RunSession(*dir_ / "capture", run, {});
    frames_ = report.frames;
    steps_ = report.steps_total;
    for (const fs::directory_entry& e : fs::recursive_directory_iterator(*dir_ / "capture")) {
      if (e.is_regular_file()) session_bytes_ += e.file_size();
    }
  }
  static void TearDownTestSuite() { delete dir_; }

  static pipelines::SimulatedStationOptions StationOptions(const fs::path& faults = {}) {
    pipelines::SimulatedStationOptions o;
    o.rig = rig_;
    o.seed = 11;
    o.faults = faults;
    o.serve_cameras = true;
    return o;
  }

  // A daemon on a station the test keeps a hand on (to clear the fault).
  std::unique_ptr<CaptureDaemon> MakeDaemon(const fs::path& state, const fs::path& faults = {},
                                            std::chrono::milliseconds retry = 50ms) {
    auto station = std::make_unique<pipelines::SimulatedStation>(StationOptions(faults));
    station_ = station.get();
    CaptureDaemonOptions o;
    o.state_dir = state;
    o.fault_retry_interval = retry;
    return std::make_unique<CaptureDaemon>(std::move(station), o);
  }

  static CaptureJob WaitFor(const CaptureDaemon& daemon, const std::string& id, JobState state) {
    const auto deadline = std::chrono::steady_clock::now() + 5min;
    while (std::chrono::steady_clock::now() < deadline) {
      const CaptureJob job = *daemon.Job(id);
      if (job.state == state) return job;
      std::this_thread::sleep_for(2ms);
    }
    ADD_FAILURE() << id << " never became " << ToString(state) << "; it is " << ToString(daemon.Job(id)->state) << ": "
                  << daemon.Job(id)->pause_reason;
    return *daemon.Job(id);
  }

  // The job ended as an undisturbed run: same files, frames counted once.
  static void ExpectTheUndisturbedSession(const CaptureDaemon& daemon, const std::string& id) {
    const CaptureJob job = *daemon.Job(id);
    EXPECT_EQ(job.state, JobState::kDone);
    EXPECT_EQ(job.frames, frames_);
    EXPECT_EQ(testing::Differences(testing::Normalized(daemon.SessionDir(id)), testing::Normalized(*dir_ / "capture")),
              "");
  }

  fs::path WriteFaults(const std::string& members) {
    const fs::path file = state_ / "faults.json";
    std::ofstream(file) << R"({"format": "mesocap.faults", "version": 1, )" << members << "}";
    return file;
  }

  static inline testing::TemporaryDirectory* dir_ = nullptr;
  static inline std::string rig_;
  static inline std::uint64_t frames_ = 0;
  static inline std::size_t steps_ = 0;
  static inline std::uintmax_t session_bytes_ = 0;
  testing::TemporaryDirectory state_;
  pipelines::SimulatedStation* station_ = nullptr;
};

TEST_P(DaemonFaultsTest, ACameraServerKilledAndStartedAgain) {
  auto daemon = MakeDaemon(state_ / "state");
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  // Killed after a different number of steps in each trial.
  const std::uint64_t after = 1 + static_cast<std::uint64_t>(GetParam()) * (steps_ / 8);
  while (daemon->Job(id)->steps_done < after) std::this_thread::sleep_for(1ms);
  station_->served_cameras()->StopServing(0);
  const CaptureJob paused = WaitFor(*daemon, id, JobState::kPaused);
  EXPECT_TRUE(paused.paused_by_fault);
  EXPECT_NE(paused.pause_reason.find("disconnected"), std::string::npos) << paused.pause_reason;
  // While it is gone, the daemon polls and waits.
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(daemon->Job(id)->state, JobState::kPaused);
  EXPECT_EQ(daemon->Job(id)->faults, 1u);
  station_->served_cameras()->ServeAgain(0);
  WaitFor(*daemon, id, JobState::kDone);
  ExpectTheUndisturbedSession(*daemon, id);
}

TEST_P(DaemonFaultsTest, AStageStalledPastTheRetries) {
  // Five stalls in a row from the n-th operation: the runner's three
  // retries cannot cure it; the next try after the pause can.
  const int n = 1 + GetParam();
  const char* stage = GetParam() % 2 == 0 ? "turntable" : "light_arc";
  std::string at;
  for (int k = n; k < n + 5; ++k) at += (at.empty() ? "" : ", ") + std::to_string(k);
  auto daemon = MakeDaemon(state_ / "state", WriteFaults(R"("stage_stall": {"device": ")" + std::string(stage) +
                                                         R"(", "at": [)" + at + "]}"));
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  WaitFor(*daemon, id, JobState::kDone);
  const CaptureJob done = *daemon->Job(id);
  EXPECT_EQ(done.faults, 1u) << stage << " from operation " << n;
  bool named = false;
  for (const DaemonEvent& e : daemon->events().After(0, 0ms)) {
    const std::string message = e.data.value("message", "");
    if (e.type == "fault")
      named = message.find(std::string(stage) == "turntable" ? "turntable" : "light") != std::string::npos;
  }
  EXPECT_TRUE(named) << stage;
  ExpectTheUndisturbedSession(*daemon, id);
}

TEST_P(DaemonFaultsTest, ALampBurntOutAndReplaced) {
  // The first two lamps in turn, at their first, second or third switch-on.
  const int lamp = GetParam() % 2, at = 1 + GetParam() / 2;
  auto daemon = MakeDaemon(
      state_ / "state",
      WriteFaults(R"("lamp_failure": {"device": )" + std::to_string(lamp) + R"(, "at": [)" + std::to_string(at) + "]}"),
      1h);  // the operator resumes it once the bulb is new
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  const CaptureJob paused = WaitFor(*daemon, id, JobState::kPaused);
  EXPECT_TRUE(paused.paused_by_fault);
  EXPECT_NE(paused.pause_reason.find("lamp " + std::to_string(lamp) + " does not light"), std::string::npos)
      << paused.pause_reason;
  station_->ReplaceLamp(lamp);
  ASSERT_EQ(daemon->Resume(id).outcome, JobCommandResult::Outcome::kDone);
  WaitFor(*daemon, id, JobState::kDone);
  ExpectTheUndisturbedSession(*daemon, id);
}

TEST_P(DaemonFaultsTest, ADiskFullAndCleaned) {
  // The state directory on a tmpfs twice the session's size, filled by a
  // ballast file but for a fraction of the session (a sixth to five
  // sixths): the capture fills the rest; deleting the ballast clears it.
  const fs::path disk = state_ / "disk";
  fs::create_directories(disk);
  const std::string options = "size=" + std::to_string(2 * session_bytes_ + (4 << 20));
  ASSERT_EQ(::mount("tmpfs", disk.c_str(), "tmpfs", 0, options.c_str()), 0)
      << "mount tmpfs at " << disk << ": " << std::strerror(errno) << " (run in scripts/in-network-namespace.sh)";
  {
    auto daemon = MakeDaemon(disk / "state");
    const std::uintmax_t room = session_bytes_ * static_cast<std::uintmax_t>(1 + GetParam()) / 6;
    const std::uintmax_t ballast = fs::space(disk).available - room;
    {
      std::ofstream out(disk / "ballast", std::ios::binary | std::ios::trunc);
      const std::string block(1 << 20, 'b');
      for (std::uintmax_t left = ballast; left > 0;) {
        const std::size_t n = static_cast<std::size_t>(std::min<std::uintmax_t>(left, block.size()));
        out.write(block.data(), static_cast<std::streamsize>(n));
        left -= n;
      }
    }
    const std::string id = daemon->Submit("capture").id;
    daemon->Start();
    const CaptureJob paused = WaitFor(*daemon, id, JobState::kPaused);
    EXPECT_TRUE(paused.paused_by_fault);
    EXPECT_NE(paused.pause_reason.find("no space left on the device"), std::string::npos) << paused.pause_reason;
    // The journal holds only whole steps: the retries after the cleaning do the rest.
    fs::remove(disk / "ballast");
    WaitFor(*daemon, id, JobState::kDone);
    ExpectTheUndisturbedSession(*daemon, id);
  }
  ASSERT_EQ(::umount2(disk.c_str(), MNT_DETACH), 0) << std::strerror(errno);
}

INSTANTIATE_TEST_SUITE_P(FiveEach, DaemonFaultsTest, ::testing::Range(0, 5));

}  // namespace
}  // namespace mesocap::acquisition
