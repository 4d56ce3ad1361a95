// The capture daemon's core, without its transport: a state directory
// holding a queue of jobs and each job's capture session, one worker that
// runs the jobs one at a time on a capture station held open between them,
// and the commands clients give (submit, pause, resume, cancel). The control
// API (acquisition/control_api.h) and the HTTP server in front of it only
// translate requests into these calls.
//
// Everything a job is lives on disk: its record (acquisition/capture_job.h)
// and its session with the runner's journal. A daemon stopped between steps
// (Stop(), on SIGTERM) or killed at any moment resumes, when started again,
// the job that was running first, from its journal.
//
// Faults that the runner's retries cannot cure (a camera gone, a stage
// stalled twice, a lamp out, a full disk) pause the job with the runner's
// message; after `fault_retry_interval` the worker runs it again, which
// resumes the failed step from its start, and pauses it again while the
// fault lasts. A client's resume retries at once.
#pragma once

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "acquisition/capture_job.h"
#include "acquisition/capture_station.h"
#include "acquisition/daemon_event_log.h"

namespace mesocap::acquisition {

struct CaptureDaemonOptions {
  std::filesystem::path state_dir;
  std::chrono::milliseconds fault_retry_interval{30000};
  // Handed to every run (timeouts, retries); show_progress is forced off.
  CaptureRunnerOptions runner;

  std::string Check() const;
};

// What a client's command did.
struct JobCommandResult {
  enum class Outcome { kDone, kNoSuchJob, kNotNow };
  Outcome outcome = Outcome::kDone;
  std::string message;  // why not, for kNoSuchJob and kNotNow
  CaptureJob job;
};

class CaptureDaemon {
 public:
  // Creates the state directory if needed and takes its lock (Error when
  // another daemon holds it), then reads every job record (FormatError
  // naming the record when one is damaged). Runs nothing until Start().
  CaptureDaemon(std::unique_ptr<CaptureStation> station, CaptureDaemonOptions options);
  ~CaptureDaemon();  // Stop()
  CaptureDaemon(const CaptureDaemon&) = delete;
  CaptureDaemon& operator=(const CaptureDaemon&) = delete;

  void Start();
  // Lets the running step finish and journal, leaves its job "running" (the
  // next start resumes it), and ends the worker. Idempotent.
  void Stop();

  CaptureJob Submit(const std::string& plan_kind);
  std::vector<CaptureJob> Jobs() const;
  std::optional<CaptureJob> Job(const std::string& id) const;
  JobCommandResult Pause(const std::string& id);
  JobCommandResult Resume(const std::string& id);
  JobCommandResult Cancel(const std::string& id);

  std::string rig_name() const;
  // The job the worker runs now, or empty.
  std::string running_job() const;
  std::filesystem::path SessionDir(const std::string& id) const;
  DaemonEventLog& events() { return events_; }

 private:
  void RunWorker();
  // The next job to run, or nullptr; under mutex_.
  CaptureJob* NextJob(std::chrono::steady_clock::time_point now,
                      std::optional<std::chrono::steady_clock::time_point>* wake_at);
  void RunJob(const std::string& id);
  // Writes the record and announces the change; under mutex_. A record that
  // cannot be written (a full disk) keeps its last good state on disk.
  void Save(const CaptureJob& job, const std::string& event_type = "job");
  void Log(const std::string& line);
  std::filesystem::path RecordPath(const std::string& id) const;

  std::unique_ptr<CaptureStation> station_;
  CaptureDaemonOptions options_;
  int lock_fd_ = -1;
  DaemonEventLog events_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::map<std::string, CaptureJob> jobs_;  // by id, which is submission order
  std::map<std::string, std::chrono::steady_clock::time_point> retry_at_;  // fault-paused jobs
  std::uint64_t next_number_ = 1;
  std::string running_;
  bool stopping_ = false;
  std::thread worker_;
};

}  // namespace mesocap::acquisition
