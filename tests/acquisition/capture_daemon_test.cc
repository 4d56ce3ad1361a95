// The capture daemon's core on the simulated rig (the tiny rig cut to one
// sweep): jobs run in submission order to the same session an uninterrupted
// direct run records; pause, cancel, a stop and a restart, and a fault the
// runner cannot cure all end with that same session.
#include "acquisition/capture_daemon.h"

#include <gtest/gtest.h>

#include "core/error.h"
#include "tests/acquisition/simulated_daemon.h"

namespace mesocap::acquisition {
namespace {

TEST_F(SimulatedDaemonTest, RunsJobsInOrderToTheSessionsADirectRunRecords) {
  auto daemon = MakeDaemon();
  const CaptureJob capture = daemon->Submit("capture");
  const CaptureJob calibration = daemon->Submit("calibration");
  EXPECT_EQ(capture.id, "job-000001");
  EXPECT_EQ(calibration.id, "job-000002");
  EXPECT_THROW(daemon->Submit("sweep"), core::Error);
  daemon->Start();
  const CaptureJob done = WaitFor(*daemon, calibration.id, JobState::kDone);
  const CaptureJob first = *daemon->Job(capture.id);
  EXPECT_EQ(first.state, JobState::kDone);
  EXPECT_EQ(first.steps_done, first.steps_total);
  EXPECT_EQ(first.frames, capture_frames_);
  EXPECT_EQ(SessionDifferences(*daemon, capture.id, "capture"), "");
  EXPECT_EQ(SessionDifferences(*daemon, calibration.id, "calibration"), "");
  // The records on disk say what the daemon says.
  EXPECT_EQ(ToJson(ReadCaptureJob(state_ / "state" / "jobs" / "job-000002.json")), ToJson(done));
}

TEST_F(SimulatedDaemonTest, PauseStopsBetweenStepsAndResumeCompletesTheSameSession) {
  auto daemon = MakeDaemon();
  const std::string id = daemon->Submit("capture").id;
  // Paused while queued, it waits; a later job runs meanwhile.
  ASSERT_EQ(daemon->Pause(id).outcome, JobCommandResult::Outcome::kDone);
  const std::string other = daemon->Submit("calibration").id;
  daemon->Start();
  WaitFor(*daemon, other, JobState::kDone);
  EXPECT_EQ(daemon->Job(id)->state, JobState::kPaused);
  EXPECT_EQ(daemon->Job(id)->steps_done, 0u);
  ASSERT_EQ(daemon->Resume(id).outcome, JobCommandResult::Outcome::kDone);
  // Paused while running: it stops after a step and keeps what it did.
  while (daemon->Job(id)->steps_done == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  daemon->Pause(id);
  const CaptureJob paused = WaitFor(*daemon, id, JobState::kPaused);
  EXPECT_EQ(paused.pause_reason, "paused by a client");
  EXPECT_FALSE(paused.paused_by_fault);
  EXPECT_LT(paused.steps_done, paused.steps_total);
  EXPECT_EQ(daemon->Resume(id).outcome, JobCommandResult::Outcome::kDone);
  const CaptureJob done = WaitFor(*daemon, id, JobState::kDone);
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
  // What cannot be done now is refused with the job's state.
  const JobCommandResult again = daemon->Pause(id);
  EXPECT_EQ(again.outcome, JobCommandResult::Outcome::kNotNow);
  EXPECT_EQ(again.message, "job " + id + " is done: cannot pause it");
  EXPECT_EQ(daemon->Cancel("job-000099").outcome, JobCommandResult::Outcome::kNoSuchJob);
}

TEST_F(SimulatedDaemonTest, CancelStopsBetweenStepsAndKeepsTheSession) {
  auto daemon = MakeDaemon();
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  while (daemon->Job(id)->steps_done == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  daemon->Cancel(id);
  const CaptureJob cancelled = WaitFor(*daemon, id, JobState::kCancelled);
  EXPECT_LT(cancelled.steps_done, cancelled.steps_total);
  EXPECT_TRUE(fs::exists(daemon->SessionDir(id) / "journal.jsonl"));
  EXPECT_EQ(daemon->Resume(id).outcome, JobCommandResult::Outcome::kNotNow);
}

TEST_F(SimulatedDaemonTest, StopLeavesTheJobRunningAndARestartResumesItToTheSameSession) {
  std::string id;
  std::uint64_t steps_at_stop = 0;
  {
    auto daemon = MakeDaemon();
    id = daemon->Submit("capture").id;
    daemon->Start();
    while (daemon->Job(id)->steps_done < 2) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    daemon->Stop();
    const CaptureJob stopped = *daemon->Job(id);
    EXPECT_EQ(stopped.state, JobState::kRunning);
    ASSERT_LT(stopped.steps_done, stopped.steps_total);
    steps_at_stop = stopped.steps_done;
  }
  auto daemon = MakeDaemon();
  const CaptureJob before = *daemon->Job(id);
  EXPECT_EQ(before.state, JobState::kRunning);
  EXPECT_EQ(before.steps_done, steps_at_stop);
  daemon->Start();
  const CaptureJob done = WaitFor(*daemon, id, JobState::kDone);
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
  // Frames are counted once: the two runs' frames add up to a whole run's.
  EXPECT_EQ(done.frames, capture_frames_);
}

TEST_F(SimulatedDaemonTest, OnlyOneDaemonPerStateDirectory) {
  auto daemon = MakeDaemon();
  try {
    MakeDaemon();
    FAIL() << "a second daemon took the lock";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("another mesocapd uses this state directory"), std::string::npos) << e.what();
  }
}

TEST_F(SimulatedDaemonTest, AFaultTheRetriesCannotCurePausesTheJobUntilTheDeviceIsBack) {
  // The turntable stalls on five moves in a row: the runner's three
  // retries cannot cure it, the job pauses, and the next try succeeds.
  const fs::path faults = state_ / "faults.json";
  std::ofstream(faults) << R"({"format": "mesocap.faults", "version": 1,
    "stage_stall": {"device": "turntable", "at": [2, 3, 4, 5, 6]}})";
  auto daemon = MakeDaemon(faults, std::chrono::milliseconds(50));
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  const CaptureJob done = WaitFor(*daemon, id, JobState::kDone);
  EXPECT_GE(done.faults, 1u);
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
  // The pause said which device and why.
  bool paused_on_stall = false;
  for (const DaemonEvent& e : daemon->events().After(0, std::chrono::milliseconds(0))) {
    if (e.type == "fault" && e.data.value("message", "").find("turntable") != std::string::npos) {
      paused_on_stall = true;
    }
  }
  EXPECT_TRUE(paused_on_stall);
}

TEST_F(SimulatedDaemonTest, ADamagedJobRecordIsNamedAtStart) {
  { auto daemon = MakeDaemon(); daemon->Submit("capture"); }
  std::ofstream(state_ / "state" / "jobs" / "job-000001.json") << R"({"format": "mesocap.capture_job", "version": 1})";
  try {
    MakeDaemon();
    FAIL() << "a damaged record was read";
  } catch (const core::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("job-000001.json"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mesocap::acquisition
