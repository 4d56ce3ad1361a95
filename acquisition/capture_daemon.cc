#include "acquisition/capture_daemon.h"

#include <fcntl.h>
#include <spdlog/spdlog.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "acquisition/capture_plan.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_io.h"
#include "formats/capture_session.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kJobsFolder = "jobs";
constexpr const char* kSessionsFolder = "sessions";
constexpr const char* kLockFile = "mesocapd.lock";

// The state folder and what the daemon makes in it are its user's and
// group's, whatever the umask it was started under.
void SetMode(const fs::path& path, fs::perms mode) {
  std::error_code ec;
  fs::permissions(path, mode, ec);
  if (ec) throw core::Error(path.string() + ": cannot set its mode: " + ec.message());
}

constexpr fs::perms kFolderMode = fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec;

// The highest job number that names a folder in `sessions`, or 0.
std::uint64_t HighestSessionNumber(const fs::path& sessions) {
  std::uint64_t highest = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(sessions)) {
    const std::string name = entry.path().filename().string();
    if (IsJobId(name)) highest = std::max(highest, JobNumber(name));
  }
  return highest;
}

JobCommandResult NoSuchJob(const std::string& id) {
  return {JobCommandResult::Outcome::kNoSuchJob, "no job " + core::Quoted(id), {}};
}

JobCommandResult NotNow(const CaptureJob& job, const std::string& what) {
  return {JobCommandResult::Outcome::kNotNow,
          "job " + job.id + " is " + std::string(ToString(job.state)) + ": cannot " + what + " it", job};
}

}  // namespace

core::CheckResult CaptureDaemonOptions::Check() const {
  if (state_dir.empty()) return "state_dir must name the daemon's state directory";
  if (fault_retry_interval.count() < 0) return "fault_retry_interval must not be negative";
  if (idle_poll_interval.count() < 1) return "idle_poll_interval must be at least 1 ms";
  if (preview_max_side < 8 || preview_max_side > 4096) return "preview_max_side must be 8..4096 pixels";
  if (preview_interval.count() < 0) return "preview_interval must not be negative";
  if (const core::CheckResult problem = runner.Check(); !problem.empty()) return "runner: " + problem;
  return {};
}

CaptureDaemon::CaptureDaemon(std::unique_ptr<CaptureStation> station, CaptureDaemonOptions options)
    : station_(std::move(station)), options_(std::move(options)) {
  core::ThrowIfInvalid(options_.Check(), "capture daemon");
  options_.runner.show_progress = false;
  const fs::path& dir = options_.state_dir;
  fs::create_directories(dir / kJobsFolder);
  fs::create_directories(dir / kSessionsFolder);
  for (const fs::path& folder : {dir, dir / kJobsFolder, dir / kSessionsFolder}) SetMode(folder, kFolderMode);
  lock_fd_ = ::open((dir / kLockFile).c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0640);
  if (lock_fd_ < 0) throw core::Error((dir / kLockFile).string() + ": cannot open: " + std::strerror(errno));
  ::fchmod(lock_fd_, 0640);
  if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(lock_fd_);
    lock_fd_ = -1;
    throw core::Error(dir.string() + ": another mesocapd uses this state directory");
  }
  // Only this daemon writes here, so what a killed one left is stale.
  core::RemoveStaleTemporaries(dir / kJobsFolder);
  for (const fs::directory_entry& entry : fs::directory_iterator(dir / kJobsFolder)) {
    if (entry.path().extension() != ".json") continue;
    CaptureJob job = ReadCaptureJob(entry.path());
    next_number_ = std::max<std::uint64_t>(next_number_, JobNumber(job.id) + 1);
    // A fault-paused job is tried again at once after a restart: the
    // device may have come back while the daemon was down.
    if (job.state == JobState::kPaused && job.paused_by_fault) retry_at_[job.id] = Clock::now();
    // A job killed while it waited for the operator resumes its step from
    // the start, which asks again.
    if (!job.operator_prompt.empty()) {
      job.state = JobState::kRunning;
      job.operator_prompt.clear();
      job.pause_reason.clear();
    }
    jobs_.emplace(job.id, std::move(job));
  }
  // A session whose record was removed keeps its number: a new job never
  // takes it over.
  next_number_ = std::max(next_number_, HighestSessionNumber(dir / kSessionsFolder) + 1);
}

CaptureDaemon::~CaptureDaemon() {
  Stop();
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

void CaptureDaemon::Start() {
  std::lock_guard lock(mutex_);
  if (worker_.joinable() || stopping_) return;
  worker_ = std::thread([this] { RunWorker(); });
}

void CaptureDaemon::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  events_.Close();
}

fs::path CaptureDaemon::RecordPath(const std::string& id) const {
  return options_.state_dir / kJobsFolder / (id + ".json");
}

fs::path CaptureDaemon::SessionDir(const std::string& id) const { return options_.state_dir / kSessionsFolder / id; }

std::string CaptureDaemon::rig_name() const { return station_->rig_name(); }

std::string CaptureDaemon::running_job() const {
  std::lock_guard lock(mutex_);
  return running_;
}

void CaptureDaemon::Log(const std::string& line) {
  spdlog::info("{}", line);
  events_.Add("log", {{"message", line}});
}

void CaptureDaemon::Save(const CaptureJob& job, const std::string& event_type) {
  try {
    WriteCaptureJob(RecordPath(job.id), job);
  } catch (const std::exception& e) {
    spdlog::warn("{}: the job record keeps its last state on disk: {}", job.id, e.what());
    events_.Add("fault", {{"job", job.id}, {"message", std::string("cannot write the job record: ") + e.what()}});
  }
  events_.Add(event_type, ToJson(job));
}

CaptureJob CaptureDaemon::Submit(const std::string& plan_kind) {
  if (std::find(kPlanKinds.begin(), kPlanKinds.end(), plan_kind) == kPlanKinds.end()) {
    throw core::Error("plan " + core::Quoted(plan_kind) + ": expected \"capture\", \"btf\" or \"calibration\"");
  }
  CaptureJob job;
  {
    std::lock_guard lock(mutex_);
    job.id = JobId(next_number_);
    job.plan_kind = plan_kind;
    job.submitted_at = formats::UtcTimestamp(std::chrono::system_clock::now());
    // The record is on disk before the id is given out: a submitted job
    // survives a kill that follows.
    WriteCaptureJob(RecordPath(job.id), job);
    ++next_number_;
    jobs_.emplace(job.id, job);
    events_.Add("job", ToJson(job));
  }
  Log(job.id + " submitted (" + plan_kind + ")");
  wake_.notify_all();
  return job;
}

std::vector<CaptureJob> CaptureDaemon::Jobs() const {
  std::lock_guard lock(mutex_);
  std::vector<CaptureJob> out;
  for (const auto& [id, job] : jobs_) out.push_back(job);
  return out;
}

std::optional<CaptureJob> CaptureDaemon::Job(const std::string& id) const {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return std::nullopt;
  return it->second;
}

JobCommandResult CaptureDaemon::Pause(const std::string& id) {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return NoSuchJob(id);
  CaptureJob& job = it->second;
  if (running_ == id && (job.state == JobState::kRunning || !job.operator_prompt.empty())) {
    job.pause_requested = true;  // the worker pauses it between steps, or ends its operator prompt
    wake_.notify_all();
  } else if (job.state == JobState::kQueued || job.state == JobState::kRunning) {
    job.state = JobState::kPaused;
    job.pause_reason = "paused by a client";
    job.paused_by_fault = false;
  } else if (job.state != JobState::kPaused) {
    return NotNow(job, "pause");
  }
  Save(job);
  return {JobCommandResult::Outcome::kDone, {}, job};
}

JobCommandResult CaptureDaemon::Resume(const std::string& id) {
  JobCommandResult result;
  {
    std::lock_guard lock(mutex_);
    const auto it = jobs_.find(id);
    if (it == jobs_.end()) return NoSuchJob(id);
    CaptureJob& job = it->second;
    if (!job.operator_prompt.empty()) {
      return {JobCommandResult::Outcome::kNotNow,
              "job " + id + " waits for the operator (" + job.operator_prompt + "): acknowledge it with ack", job};
    }
    if (job.state == JobState::kPaused) {
      job.state = JobState::kQueued;
      job.pause_reason.clear();
      job.paused_by_fault = false;
      retry_at_.erase(id);
    } else if (job.state == JobState::kRunning) {
      job.pause_requested = false;
    } else if (job.state != JobState::kQueued) {
      return NotNow(job, "resume");
    }
    Save(job);
    result.job = job;
  }
  wake_.notify_all();
  return result;
}

JobCommandResult CaptureDaemon::Cancel(const std::string& id) {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return NoSuchJob(id);
  CaptureJob& job = it->second;
  if (IsFinished(job.state)) return NotNow(job, "cancel");
  if (running_ == id) {
    job.cancel_requested = true;  // the worker cancels it between steps, or ends its operator prompt
    wake_.notify_all();
  } else {
    job.state = JobState::kCancelled;
    retry_at_.erase(id);
  }
  Save(job);
  return {JobCommandResult::Outcome::kDone, {}, job};
}

JobCommandResult CaptureDaemon::Ack(const std::string& id) {
  std::lock_guard lock(mutex_);
  const auto it = jobs_.find(id);
  if (it == jobs_.end()) return NoSuchJob(id);
  CaptureJob& job = it->second;
  if (job.operator_prompt.empty()) {
    return {JobCommandResult::Outcome::kNotNow, "job " + id + " waits for no operator step", job};
  }
  job.operator_prompt.clear();
  wake_.notify_all();
  return {JobCommandResult::Outcome::kDone, {}, job};
}

JobCommandResult CaptureDaemon::Forget(const std::string& id, bool delete_session) {
  {
    std::lock_guard lock(mutex_);
    const auto it = jobs_.find(id);
    if (it == jobs_.end()) return NoSuchJob(id);
    if (!IsFinished(it->second.state)) return NotNow(it->second, "forget");
    // The record first: a session left after a failed removal belongs to no
    // job, and its number is still never given again.
    std::error_code ec;
    fs::remove(RecordPath(id), ec);
    if (ec) throw core::Error(RecordPath(id).string() + ": cannot remove: " + ec.message());
    CaptureJob job = std::move(it->second);
    jobs_.erase(it);
    retry_at_.erase(id);
    if (delete_session) {
      fs::remove_all(SessionDir(id), ec);
      if (ec) throw core::Error(SessionDir(id).string() + ": cannot remove: " + ec.message());
    }
    events_.Add("forgotten", {{"id", id}, {"session_deleted", delete_session}});
  }
  Log(id + " forgotten (its session " + (delete_session ? "deleted" : "kept in sessions/" + id) + ")");
  return {JobCommandResult::Outcome::kDone, {}, {}};
}

CaptureDaemon::RigStatus CaptureDaemon::DeviceStates() const {
  std::lock_guard lock(mutex_);
  return rig_status_;
}

std::vector<std::string> CaptureDaemon::camera_ids() const { return station_->camera_ids(); }

std::optional<CaptureDaemon::Preview> CaptureDaemon::CameraPreview(const std::string& camera_id) const {
  std::lock_guard lock(preview_mutex_);
  const auto it = previews_.find(camera_id);
  if (it == previews_.end()) return std::nullopt;
  return it->second;
}

bool CaptureDaemon::ReadDeviceStates() {
  RigStatus status;
  status.devices = station_->DeviceStates();
  status.read_at = formats::UtcTimestamp(std::chrono::system_clock::now());
  const bool all_ok =
      std::all_of(status.devices.begin(), status.devices.end(), [](const drivers::DeviceState& d) { return d.ok; });
  std::lock_guard lock(mutex_);
  rig_status_ = std::move(status);
  return all_ok;
}

void CaptureDaemon::KeepPreview(const std::string& id, const std::string& camera_id, const drivers::Frame& frame) {
  const Clock::time_point now = Clock::now();
  {
    std::lock_guard lock(preview_mutex_);
    const auto taken = preview_taken_.find(camera_id);
    if (taken != preview_taken_.end() && now - taken->second < options_.preview_interval) return;
    preview_taken_[camera_id] = now;
  }
  // Scaled outside the lock: a client reading a preview never waits for it.
  Preview preview{core::ScaledToFit(frame.image, options_.preview_max_side), frame.sequence, id};
  std::lock_guard lock(preview_mutex_);
  previews_[camera_id] = std::move(preview);
}

void CaptureDaemon::WaitForOperator(const std::string& id, const std::string& instruction) {
  std::unique_lock lock(mutex_);
  CaptureJob& job = jobs_.at(id);
  const auto interrupted = [&] { return stopping_ || job.pause_requested || job.cancel_requested; };
  if (interrupted()) throw CaptureInterrupted(id + ": stopped before the operator step: " + instruction);
  job.state = JobState::kPaused;
  job.operator_prompt = instruction;
  job.pause_reason = "waiting for the operator: " + instruction;
  Save(job, "prompt");
  spdlog::info("{} waits for the operator: {}", id, instruction);
  wake_.wait(lock, [&] { return job.operator_prompt.empty() || interrupted(); });
  const bool acknowledged = job.operator_prompt.empty();
  job.state = JobState::kRunning;
  job.operator_prompt.clear();
  job.pause_reason.clear();
  Save(job);
  if (!acknowledged) throw CaptureInterrupted(id + ": stopped while waiting for the operator: " + instruction);
  events_.Add("log", {{"message", id + ": the operator acknowledged: " + instruction}});
}

CaptureJob* CaptureDaemon::NextJob(Clock::time_point now, std::optional<Clock::time_point>* wake_at) {
  // Submission order, with the job a stop interrupted ("running") first.
  for (auto& [id, job] : jobs_) {
    if (job.state == JobState::kRunning) return &job;
  }
  for (auto& [id, job] : jobs_) {
    if (job.state == JobState::kQueued) return &job;
    if (job.state == JobState::kPaused && job.paused_by_fault) {
      const auto at = retry_at_.find(id);
      const Clock::time_point when = at == retry_at_.end() ? now : at->second;
      if (when <= now) return &job;
      if (!*wake_at || when < **wake_at) *wake_at = when;
    }
  }
  return nullptr;
}

void CaptureDaemon::RunWorker() {
  ReadDeviceStates();
  std::unique_lock lock(mutex_);
  Clock::time_point next_poll = Clock::now() + options_.idle_poll_interval;
  while (!stopping_) {
    std::optional<Clock::time_point> wake_at;
    CaptureJob* job = NextJob(Clock::now(), &wake_at);
    if (job == nullptr) {
      if (Clock::now() >= next_poll) {
        lock.unlock();
        ReadDeviceStates();
        lock.lock();
        next_poll = Clock::now() + options_.idle_poll_interval;
        continue;
      }
      wake_.wait_until(lock, wake_at ? std::min(*wake_at, next_poll) : next_poll);
      continue;
    }
    const std::string id = job->id;
    if (job->state == JobState::kPaused && job->paused_by_fault) {
      // Suspended on a fault: run again only once every device answers.
      lock.unlock();
      const bool all_ok = ReadDeviceStates();
      lock.lock();
      next_poll = Clock::now() + options_.idle_poll_interval;
      CaptureJob& suspended = jobs_.at(id);
      if (suspended.state != JobState::kPaused || !suspended.paused_by_fault) continue;  // a client acted meanwhile
      if (!all_ok) {
        retry_at_[id] = Clock::now() + options_.fault_retry_interval;
        continue;
      }
      job = &suspended;
    }
    job->state = JobState::kRunning;
    job->pause_reason.clear();
    job->paused_by_fault = false;
    retry_at_.erase(id);
    running_ = id;
    Save(*job);
    lock.unlock();
    RunJob(id);
    lock.lock();
    running_.clear();
  }
}

void CaptureDaemon::Fail(CaptureJob& job, const std::string& error) {
  job.state = JobState::kFailed;
  job.error = error;
  Save(job);
  events_.Add("log", {{"message", job.id + " failed: " + error}});
}

void CaptureDaemon::RunJob(const std::string& id) {
  const fs::path dir = SessionDir(id);
  std::string plan_kind;
  std::uint64_t dropped_before = 0, retries_before = 0;
  {
    std::lock_guard lock(mutex_);
    const CaptureJob& job = jobs_.at(id);
    plan_kind = job.plan_kind;
    dropped_before = job.dropped_frames;
    retries_before = job.retries;
  }
  {
    // A folder a job that never ran finds is no session of its own: a
    // capture of an earlier job whose record was removed, or an operator's.
    std::lock_guard lock(mutex_);
    CaptureJob& job = jobs_.at(id);
    if (!job.started) {
      std::error_code ec;
      if (fs::exists(fs::symlink_status(dir, ec))) {
        Fail(job, std::string(kSessionsFolder) + "/" + id + " exists and belongs to no job: move it away");
        return;
      }
      job.started = true;
      Save(job);
    }
  }
  Log(id + " running");
  try {
    station_->OpenSession(dir, plan_kind);
  } catch (const std::exception& e) {
    // The session cannot be made or is another capture: no retry cures that.
    std::lock_guard lock(mutex_);
    Fail(jobs_.at(id), e.what());
    return;
  }
  {
    std::lock_guard lock(mutex_);
    jobs_.at(id).steps_total = formats::ReadSessionManifest(dir).plan.size();
  }
  CaptureRunnerOptions options = options_.runner;
  options.stop_before_step = [this, id] {
    std::lock_guard lock(mutex_);
    const CaptureJob& job = jobs_.at(id);
    return stopping_ || job.pause_requested || job.cancel_requested;
  };
  options.frame_arrived = [this, id](const std::string& camera_id, const drivers::Frame& frame) {
    KeepPreview(id, camera_id, frame);
  };
  if (options_.prompt_operator) {
    options.operator_prompt = [this, id](const std::string& instruction) { WaitForOperator(id, instruction); };
  }
  Clock::time_point step_start = Clock::now();
  const CaptureStepDone step_done = [&](const CaptureRunReport& report, std::size_t journaled) {
    const Clock::time_point now = Clock::now();
    ReadDeviceStates();
    std::lock_guard lock(mutex_);
    CaptureJob& job = jobs_.at(id);
    job.steps_done = journaled;
    job.steps_total = report.steps_total;
    // From the journal, not the job record, which a kill may have caught
    // between a step's journal line and the record's update.
    job.frames = report.frames_done_before + report.frames;
    job.dropped_frames = dropped_before + report.dropped_frames;
    job.retries = retries_before + report.retries;
    job.running_s += std::chrono::duration<double>(now - step_start).count();
    step_start = now;
    Save(job, "step");
  };
  try {
    const CaptureRunReport report = station_->RunSession(dir, options, step_done);
    std::lock_guard lock(mutex_);
    CaptureJob& job = jobs_.at(id);
    job.steps_total = report.steps_total;
    job.frames = report.frames_done_before + report.frames;
    if (!report.stopped) {
      job.state = JobState::kDone;
      job.steps_done = report.steps_total;
      job.pause_requested = job.cancel_requested = false;
    } else if (job.cancel_requested) {
      job.state = JobState::kCancelled;
      job.cancel_requested = job.pause_requested = false;
    } else if (job.pause_requested) {
      job.state = JobState::kPaused;
      job.pause_reason = "paused by a client";
      job.pause_requested = false;
    }  // else the daemon stops: the job stays running, and a restart resumes it
    Save(job);
    events_.Add("log", {{"message", id + " " + std::string(ToString(job.state))}});
  } catch (const CaptureInterrupted& e) {
    // A stop, pause or cancel that came while the operator was asked.
    std::lock_guard lock(mutex_);
    CaptureJob& job = jobs_.at(id);
    if (job.cancel_requested) {
      job.state = JobState::kCancelled;
    } else if (job.pause_requested) {
      job.state = JobState::kPaused;
      job.pause_reason = "paused by a client";
    }  // else the daemon stops: the job stays running, and a restart resumes it
    job.cancel_requested = job.pause_requested = false;
    Save(job);
    events_.Add("log", {{"message", std::string(e.what())}});
  } catch (const std::exception& e) {
    ReadDeviceStates();  // so that clients see which device is gone
    std::lock_guard lock(mutex_);
    CaptureJob& job = jobs_.at(id);
    job.state = job.cancel_requested ? JobState::kCancelled : JobState::kPaused;
    job.cancel_requested = job.pause_requested = false;
    if (job.state == JobState::kPaused) {
      job.paused_by_fault = true;
      job.pause_reason = e.what();
      ++job.faults;
      retry_at_[id] = Clock::now() + options_.fault_retry_interval;
    }
    spdlog::warn("{} paused: {}", id, e.what());
    events_.Add("fault", {{"job", id}, {"message", e.what()}});
    Save(job);
  }
}

}  // namespace mesocap::acquisition
