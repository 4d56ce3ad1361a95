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
// message (the suspenders of Bluesky's run engine). Every
// `fault_retry_interval` the worker reads the rig's device states (the
// station reopens what came back); once every device answers it runs the
// job again, which resumes the failed step from its start, and pauses it
// again while the fault lasts. A client's resume retries at once.
//
// With `prompt_operator`, each step no motor does (lay a plate, remount the
// laser) pauses the job with an operator prompt until a client
// acknowledges it (Ack); the step then goes on.
//
// The worker also keeps what clients look at: the device states it read
// last (between steps, and every `idle_poll_interval` when idle) and the
// latest frame of each camera, scaled down for a preview.
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
#include "core/error.h"
#include "core/image.h"
#include "drivers/device_state.h"

namespace mesocap::acquisition {

struct CaptureDaemonOptions {
  std::filesystem::path state_dir;
  std::chrono::milliseconds fault_retry_interval{30000};
  std::chrono::milliseconds idle_poll_interval{5000};
  bool prompt_operator = false;
  // A camera's preview is at most this many pixels on its longer side,
  // taken from at most one frame per camera every preview_interval.
  int preview_max_side = 320;
  std::chrono::milliseconds preview_interval{250};
  // Handed to every run (timeouts, retries); show_progress is forced off.
  CaptureRunnerOptions runner;

  core::CheckResult Check() const;
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
  // The person at the rig did what the job's operator prompt asked.
  JobCommandResult Ack(const std::string& id);
  // Removes a finished job's record, and its session with `delete_session`
  // (kept otherwise, under sessions/ID). Error when a file cannot be removed.
  JobCommandResult Forget(const std::string& id, bool delete_session);

  // What the worker read last from the rig's devices, and when (UTC; empty
  // before the first reading).
  struct RigStatus {
    std::vector<drivers::DeviceState> devices;
    std::string read_at;
  };
  RigStatus DeviceStates() const;
  // The rig's camera ids, and a camera's latest preview (nullopt when it has
  // delivered no frame yet, or the id is not one of the rig's cameras).
  std::vector<std::string> camera_ids() const;
  struct Preview {
    core::Image image;  // linear, scaled to fit preview_max_side
    std::uint64_t sequence = 0;
    std::string job;  // the job whose capture took it
  };
  std::optional<Preview> CameraPreview(const std::string& camera_id) const;

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
  // Marks the job failed with `error`; under mutex_.
  void Fail(CaptureJob& job, const std::string& error);
  // Reads every device's state through the station; on the worker thread.
  // True when every device answers.
  bool ReadDeviceStates();
  // The operator prompt of job `id`: pauses it until Ack, or throws
  // CaptureInterrupted when the daemon stops or a client pauses or cancels.
  void WaitForOperator(const std::string& id, const std::string& instruction);
  void KeepPreview(const std::string& id, const std::string& camera_id, const drivers::Frame& frame);
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
  std::map<std::string, CaptureJob, JobIdOrder> jobs_;                     // by id, which is submission order
  std::map<std::string, std::chrono::steady_clock::time_point> retry_at_;  // fault-paused jobs
  std::uint64_t next_number_ = 1;
  std::string running_;
  bool stopping_ = false;
  RigStatus rig_status_;
  std::thread worker_;

  // Previews are kept on the worker's thread while a capture runs, and read
  // by clients: a lock of their own, so a preview never waits for the queue.
  mutable std::mutex preview_mutex_;
  std::map<std::string, Preview> previews_;
  std::map<std::string, std::chrono::steady_clock::time_point> preview_taken_;
};

}  // namespace mesocap::acquisition
