// One job of the capture daemon's queue: a capture session of one plan kind
// on the daemon's rig, its state and its progress. Each job's record is a
// file of its own in the state directory (docs/FORMATS.md "Capture daemon
// state"), written atomically at every change, so a daemon killed at any
// moment finds every job as it last was.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <string_view>

#include "core/enum_text.h"

namespace mesocap::acquisition {

// queued -> running -> done | failed; running <-> paused; any but done and
// failed -> cancelled. A job stays "running" when the daemon stops (SIGTERM
// or a kill): the next start resumes it first.
enum class JobState { kQueued, kRunning, kPaused, kDone, kFailed, kCancelled };

constexpr auto EnumNamesOf(JobState) {
  return std::to_array({"queued", "running", "paused", "done", "failed", "cancelled"});
}
using core::ToString;
// done, failed and cancelled: nothing more happens to the job.
bool IsFinished(JobState state);

struct CaptureJob {
  std::string id;         // "job-000001": the order of submission (JobNumber)
  std::string plan_kind;  // "capture" or "calibration" (acquisition/capture_plan.h)
  JobState state = JobState::kQueued;
  // Why a paused job waits: a client's pause, or the fault that the
  // runner's retries could not cure (its message). Empty otherwise.
  std::string pause_reason;
  bool paused_by_fault = false;
  // What the person at the rig is asked to do while the job waits for
  // their acknowledgement (the job is paused meanwhile). Empty otherwise.
  std::string operator_prompt;
  std::string error;         // why a failed job failed
  std::string submitted_at;  // UTC, ISO 8601
  std::uint64_t steps_done = 0;
  std::uint64_t steps_total = 0;  // 0 until the session is opened
  std::uint64_t frames = 0;       // frames delivered, over every run of the job
  std::uint64_t dropped_frames = 0;
  std::uint64_t retries = 0;
  std::uint64_t faults = 0;       // pauses on faults so far
  double running_s = 0;           // wall time spent running steps, over every run
  bool cancel_requested = false;  // a cancel of a running job, until it stops between steps
  bool pause_requested = false;   // likewise for a pause
  // The worker has begun it once: its session folder, if any, is its own.
  // A job that never ran refuses a folder it finds there.
  bool started = false;

  // Seconds left at the pace of the steps run so far; nullopt before the first.
  std::optional<double> EtaSeconds() const;
};

nlohmann::json ToJson(const CaptureJob& job);
// Reads a job record, checking every field; FormatError names the file and field.
CaptureJob ReadCaptureJob(const std::filesystem::path& file);
void WriteCaptureJob(const std::filesystem::path& file, const CaptureJob& job);

// Whether `id` has the form the daemon gives ("job-" and the number in at
// least six digits, no more leading zeros than that), so a client's path
// never reaches the file system and each number has one id.
bool IsJobId(std::string_view id);
std::string JobId(std::uint64_t number);
// The number of an id that IsJobId accepts.
std::uint64_t JobNumber(std::string_view id);

// Orders ids by number ("job-999999" before "job-1000000").
struct JobIdOrder {
  bool operator()(std::string_view a, std::string_view b) const {
    return a.size() != b.size() ? a.size() < b.size() : a < b;
  }
};

}  // namespace mesocap::acquisition
