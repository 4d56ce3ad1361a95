// Runs a capture session's plan on a rig (MDF paper Sec. 3.1-3.2): moves the
// turntable and the light arc, switches lamps and the laser, tilts the
// stripe across the sample, triggers every camera and writes what they
// deliver (or, for a sweep the plan stores as an analysis, what the
// streaming analysis makes of it), journaling each step once all its files
// are on disk. The same code drives the simulated rig (`mesocap simulate`)
// and, later, the real one: it sees only the drivers/ interfaces and the
// operator.
//
// Faults: a grab that times out is triggered again; a move that times out
// is waited for again, a stalled stage is homed and moved again; each at
// most `retries` times per operation. A disconnected camera, a burnt-out
// lamp or retries used up end the run with an Error naming the step and the
// device; the journal keeps every finished step, so running again resumes
// where it stopped (leftover temporary files of the interrupted step are
// removed first). Dropped frames cost nothing but time: in software
// trigger mode the camera delivers the next exposure of the same state.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "acquisition/prompted_operator.h"
#include "core/error.h"
#include "drivers/rig.h"
#include "drivers/rig_operator.h"
#include "formats/calibration.h"
#include "mdf/session_sweeps.h"
#include "mdf/space_time_analyzer.h"

namespace mesocap::acquisition {

struct CaptureRunnerOptions {
  std::chrono::milliseconds frame_timeout{2000};
  std::chrono::milliseconds move_timeout{120000};
  int retries = 3;
  bool show_progress = true;
  // The rig's calibration, needed when the plan stores sweep analyses
  // (formats::LaserSweepStep::stores_analysis): each sweep is then streamed
  // through line detection and space-time analysis (mdf/laser_sweep.h) as
  // its frames arrive, with the laser planes from the session's own
  // calibration plates (mdf/session_sweeps.h), and only the analysis is
  // written. Not owned.
  const formats::Calibration* calibration = nullptr;
  mdf::SweepGeometryOptions sweep_geometry;
  mdf::SpaceTimeOptions space_time;
  // How the user resumes this session ("mesocap simulate --resume ..."),
  // for the error when a device stops the capture; empty: "run the capture
  // again".
  std::string resume_command;
  // Asked before each step that is still to do: true ends the run there,
  // lamps and laser off, with CaptureRunReport::stopped set (the journal
  // holds every finished step, so a later run resumes). How a daemon pauses,
  // cancels or shuts down between steps, never inside one.
  std::function<bool()> stop_before_step;
  // Called with every frame a camera delivers, as it arrives (a daemon's
  // live preview); must return quickly, the capture waits meanwhile.
  std::function<void(const std::string& camera_id, const drivers::Frame& frame)> frame_arrived;
  // When set, the operator's actions are asked of a person through it first
  // (acquisition/prompted_operator.h); it may end the run by throwing
  // CaptureInterrupted, which RunCaptureSession passes on with the lamps
  // and laser off and the step not journaled.
  OperatorPrompt operator_prompt;

  core::CheckResult Check() const;
};

// What a run did, for the log and for tests.
struct CaptureRunReport {
  std::size_t steps_total = 0;        // in the plan
  std::size_t steps_done_before = 0;  // journaled and intact when the run began
  std::size_t steps_redone = 0;       // journaled, but a file was damaged: captured again
  std::size_t steps_run = 0;
  std::size_t stale_temporaries_removed = 0;
  // The frames of the steps journaled when the run began, as the plan has
  // them: with `frames`, the session's frames however often it was stopped.
  std::uint64_t frames_done_before = 0;
  std::uint64_t frames = 0;          // this run's
  std::uint64_t dropped_frames = 0;  // sequence gaps the cameras reported
  std::uint64_t retries = 0;         // grabs, moves and tilts tried again
  bool stopped = false;              // stop_before_step ended the run early
};

// Called after each journaled step with the run's report so far and the
// number of steps journaled (of report.steps_total).
using CaptureStepDone = std::function<void(const CaptureRunReport& report, std::size_t steps_journaled)>;

// Runs every step of the session at `dir` (created with its manifest, see
// formats/capture_session.h) that its journal does not hold yet, in plan
// order. The rig must have the cameras the plan's files name (by id) and a
// turntable, light arc, lamp bank and laser unit. Throws Error as described
// above; a step of kind "other" is refused before anything moves.
CaptureRunReport RunCaptureSession(const std::filesystem::path& dir, drivers::Rig& rig,
                                   drivers::RigOperator& rig_operator, const CaptureRunnerOptions& options = {},
                                   const CaptureStepDone& step_done = {});

}  // namespace mesocap::acquisition
