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

TEST_F(SimulatedDaemonTest, AJobRecordOneStepBehindItsJournalStillCountsEveryFrameOnce) {
  // kill -9 between a step's journal line and the job record's update: the
  // record says a step less, with fewer frames, than the session holds.
  std::string id;
  {
    auto daemon = MakeDaemon();
    id = daemon->Submit("capture").id;
    daemon->Start();
    while (daemon->Job(id)->steps_done < 2) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    daemon->Stop();
  }
  const fs::path record = state_ / "state" / "jobs" / (id + ".json");
  CaptureJob behind = ReadCaptureJob(record);
  ASSERT_GE(behind.steps_done, 2u);
  behind.steps_done -= 1;
  behind.frames = 0;
  WriteCaptureJob(record, behind);
  auto daemon = MakeDaemon();
  daemon->Start();
  const CaptureJob done = WaitFor(*daemon, id, JobState::kDone);
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
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
  {
    auto daemon = MakeDaemon();
    daemon->Submit("capture");
  }
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

namespace mesocap::acquisition {
namespace {

// What the operator was asked, in order, acknowledging each prompt as it
// comes until the job is in `state`.
std::vector<std::string> AcknowledgeUntil(CaptureDaemon& daemon, const std::string& id, JobState state) {
  std::vector<std::string> prompts;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(10);
  while (daemon.Job(id)->state != state && std::chrono::steady_clock::now() < deadline) {
    const CaptureJob job = *daemon.Job(id);
    if (!job.operator_prompt.empty()) {
      EXPECT_EQ(job.state, JobState::kPaused);
      EXPECT_EQ(job.pause_reason, "waiting for the operator: " + job.operator_prompt);
      prompts.push_back(job.operator_prompt);
      EXPECT_EQ(daemon.Ack(id).outcome, JobCommandResult::Outcome::kDone);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  EXPECT_EQ(daemon.Job(id)->state, state);
  return prompts;
}

TEST_F(SimulatedDaemonTest, OperatorStepsPauseTheJobUntilAcknowledged) {
  auto daemon = MakeDaemon({}, std::chrono::milliseconds(0), /*prompt_operator=*/true);
  const std::string id = daemon->Submit("capture").id;
  EXPECT_EQ(daemon->Ack(id).outcome, JobCommandResult::Outcome::kNotNow);  // nothing asked yet
  daemon->Start();
  // The first operator step of the capture: the laser plate of Sec. 3.2.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(5);
  while (daemon->Job(id)->operator_prompt.empty() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  const CaptureJob asking = *daemon->Job(id);
  ASSERT_FALSE(asking.operator_prompt.empty());
  EXPECT_EQ(asking.state, JobState::kPaused);
  EXPECT_FALSE(asking.paused_by_fault);
  // The record on disk says so too, and nothing moves until the answer.
  EXPECT_EQ(ReadCaptureJob(state_ / "state" / "jobs" / (id + ".json")).operator_prompt, asking.operator_prompt);
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  EXPECT_EQ(daemon->Job(id)->steps_done, asking.steps_done);
  // A resume is not an answer.
  const JobCommandResult resume = daemon->Resume(id);
  EXPECT_EQ(resume.outcome, JobCommandResult::Outcome::kNotNow);
  EXPECT_NE(resume.message.find("acknowledge it with ack"), std::string::npos) << resume.message;
  const std::vector<std::string> prompts = AcknowledgeUntil(*daemon, id, JobState::kDone);
  // One plate laid and taken off per calibration height, at least.
  ASSERT_GE(prompts.size(), 4u);
  EXPECT_NE(prompts.front().find("Lay the flat calibration plate over the turntable"), std::string::npos)
      << prompts.front();
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
  EXPECT_EQ(daemon->Ack(id).outcome, JobCommandResult::Outcome::kNotNow);
}

TEST_F(SimulatedDaemonTest, AStopWhileTheOperatorIsAskedResumesTheStepAndAsksAgain) {
  std::string id, first_prompt;
  {
    auto daemon = MakeDaemon({}, std::chrono::milliseconds(0), true);
    id = daemon->Submit("capture").id;
    daemon->Start();
    while (daemon->Job(id)->operator_prompt.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    first_prompt = daemon->Job(id)->operator_prompt;
    daemon->Stop();  // SIGTERM while the prompt waits
    EXPECT_EQ(daemon->Job(id)->state, JobState::kRunning);
    EXPECT_EQ(daemon->Job(id)->operator_prompt, "");
  }
  auto daemon = MakeDaemon({}, std::chrono::milliseconds(0), true);
  daemon->Start();
  const std::vector<std::string> prompts = AcknowledgeUntil(*daemon, id, JobState::kDone);
  ASSERT_FALSE(prompts.empty());
  EXPECT_EQ(prompts.front(), first_prompt);
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
}

TEST_F(SimulatedDaemonTest, APauseOrCancelWhileTheOperatorIsAskedEndsThePrompt) {
  auto daemon = MakeDaemon({}, std::chrono::milliseconds(0), true);
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  while (daemon->Job(id)->operator_prompt.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_EQ(daemon->Pause(id).outcome, JobCommandResult::Outcome::kDone);
  // The job is paused already (by the prompt); the client's pause ends the prompt.
  while (!daemon->Job(id)->operator_prompt.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  const CaptureJob paused = WaitFor(*daemon, id, JobState::kPaused);
  EXPECT_EQ(paused.pause_reason, "paused by a client");
  EXPECT_EQ(paused.operator_prompt, "");
  ASSERT_EQ(daemon->Resume(id).outcome, JobCommandResult::Outcome::kDone);
  while (daemon->Job(id)->operator_prompt.empty()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_EQ(daemon->Cancel(id).outcome, JobCommandResult::Outcome::kDone);
  WaitFor(*daemon, id, JobState::kCancelled);
}

TEST_F(SimulatedDaemonTest, DeviceStatesAndCameraPreviewsFollowTheCapture) {
  auto daemon = MakeDaemon();
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  WaitFor(*daemon, id, JobState::kDone);
  const CaptureDaemon::RigStatus status = daemon->DeviceStates();
  const std::vector<std::string> cameras = daemon->camera_ids();
  ASSERT_EQ(status.devices.size(), cameras.size() + 4);  // cameras, turntable, light arc, lamps, laser
  EXPECT_FALSE(status.read_at.empty());
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    EXPECT_EQ(status.devices[i].device, "camera " + cameras[i]);
    EXPECT_TRUE(status.devices[i].ok) << status.devices[i].state;
  }
  EXPECT_EQ(status.devices[cameras.size()].device, "turntable");
  EXPECT_NE(status.devices[cameras.size()].state.find("homed"), std::string::npos);
  EXPECT_EQ(status.devices.back().device, "laser unit");
  EXPECT_NE(status.devices.back().state.find("off"), std::string::npos);  // the capture switched it off
  // Each camera's preview is its last frame, scaled to fit and PNG-encoded.
  for (const std::string& camera : cameras) {
    const std::optional<CaptureDaemon::Preview> preview = daemon->CameraPreview(camera);
    ASSERT_TRUE(preview) << camera;
    EXPECT_EQ(preview->job, id);
    EXPECT_LE(std::max(preview->image.width(), preview->image.height()), 320);
    EXPECT_GT(preview->sequence, 0u);
  }
  EXPECT_FALSE(daemon->CameraPreview("no-such-camera"));
}

// A camera that is gone pauses the job; the daemon reads the devices at each
// retry and runs the job again only once every device answers.
TEST_F(SimulatedDaemonTest, AJobPausedOnAGoneCameraWaitsWhileTheCameraDoesNotAnswer) {
  const fs::path faults = state_ / "faults.json";
  std::ofstream(faults) << R"({"format": "mesocap.faults", "version": 1,
    "camera_disconnect": {"at": [5]}})";
  auto daemon = MakeDaemon(faults, std::chrono::milliseconds(20));
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  const CaptureJob paused = WaitFor(*daemon, id, JobState::kPaused);
  EXPECT_TRUE(paused.paused_by_fault);
  EXPECT_NE(paused.pause_reason.find("disconnected"), std::string::npos) << paused.pause_reason;
  // Many retry intervals later: still paused, not run again and failed again.
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  const CaptureJob later = *daemon->Job(id);
  EXPECT_EQ(later.state, JobState::kPaused);
  EXPECT_EQ(later.faults, 1u);
  bool camera_reported_gone = false;
  for (const drivers::DeviceState& d : daemon->DeviceStates().devices) {
    if (d.kind == "camera" && !d.ok) camera_reported_gone = d.state.find("disconnected") != std::string::npos;
  }
  EXPECT_TRUE(camera_reported_gone);
}

}  // namespace
}  // namespace mesocap::acquisition
