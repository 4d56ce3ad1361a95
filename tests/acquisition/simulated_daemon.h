// A capture daemon on the simulated rig (the tiny rig cut to one sweep, a
// session in about a second), with the sessions an uninterrupted direct run
// of the same station records, to compare the daemon's against.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <thread>

#include "acquisition/capture_daemon.h"
#include "pipelines/simulated_station.h"
#include "tests/common/normalized_tree.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::acquisition {

namespace fs = std::filesystem;

class SimulatedDaemonTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TemporaryDirectory();
    rig_ = testing::WriteRig(*dir_ / "rig.json");
    pipelines::SimulatedStation station(StationOptions());
    CaptureRunnerOptions run;
    run.show_progress = false;
    for (const char* kind : {"capture", "calibration"}) {
      station.OpenSession(*dir_ / kind, kind);
      const CaptureRunReport report = station.RunSession(*dir_ / kind, run, {});
      if (std::string(kind) == "capture") capture_frames_ = report.frames;
    }
  }
  static void TearDownTestSuite() { delete dir_; }

  static pipelines::SimulatedStationOptions StationOptions(const fs::path& faults = {}) {
    pipelines::SimulatedStationOptions o;
    o.rig = rig_;
    o.seed = 7;
    o.faults = faults;
    return o;
  }
  std::unique_ptr<CaptureDaemon> MakeDaemon(const fs::path& faults = {},
                                            std::chrono::milliseconds retry = std::chrono::milliseconds(0),
                                            bool prompt_operator = false) {
    CaptureDaemonOptions o;
    o.state_dir = state_ / "state";
    o.fault_retry_interval = retry;
    o.prompt_operator = prompt_operator;
    o.preview_interval = std::chrono::milliseconds(0);  // every frame: the latest is the last one delivered
    return std::make_unique<CaptureDaemon>(std::make_unique<pipelines::SimulatedStation>(StationOptions(faults)), o);
  }
  // Polls until the job is in `state`; fails the test after `seconds`.
  static CaptureJob WaitFor(const CaptureDaemon& daemon, const std::string& id, JobState state, double seconds = 600) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (std::chrono::steady_clock::now() < deadline) {
      const std::optional<CaptureJob> job = daemon.Job(id);
      if (job && job->state == state) return *job;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ADD_FAILURE() << id << " never became " << ToString(state) << "; it is " << ToString(daemon.Job(id)->state) << " "
                  << daemon.Job(id)->pause_reason;
    return *daemon.Job(id);
  }
  std::string SessionDifferences(const CaptureDaemon& daemon, const std::string& id, const char* kind) {
    return testing::Differences(testing::Normalized(daemon.SessionDir(id)), testing::Normalized(*dir_ / kind));
  }

  static inline testing::TemporaryDirectory* dir_ = nullptr;
  static inline std::string rig_;
  static inline std::uint64_t capture_frames_ = 0;
  testing::TemporaryDirectory state_;
};

}  // namespace mesocap::acquisition
