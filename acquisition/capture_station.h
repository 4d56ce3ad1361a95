// The rig a capture daemon holds open: its devices, built once from a rig
// description and kept between sessions, and how a session of each plan
// kind is started on it. A real rig and the simulated one (whose scene is
// the sample on the turntable) are both stations; the daemon sees only this.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "acquisition/capture_session_runner.h"
#include "drivers/device_state.h"

namespace mesocap::acquisition {

class CaptureStation {
 public:
  virtual ~CaptureStation() = default;

  virtual std::string rig_name() const = 0;
  // Creates the session of `plan_kind` (one of kPlanKinds, capture_plan.h) at `dir`
  // (a folder that does not exist yet, or one whose creation was
  // interrupted); when `dir` already holds a session, checks that it
  // records the same capture on this rig. Throws Error naming what differs.
  virtual void OpenSession(const std::filesystem::path& dir, const std::string& plan_kind) = 0;
  // Runs the session at `dir` through RunCaptureSession on the station's
  // devices, with the station's calibration for sweep analyses.
  // The rig's camera ids, in the rig description's order.
  virtual std::vector<std::string> camera_ids() const = 0;
  // Every device's state now (drivers/device_state.h). A device that was
  // gone and answers again (a camera back on the network) is reopened
  // first. Called on the thread that runs sessions, never during a step.
  virtual std::vector<drivers::DeviceState> DeviceStates() = 0;
  virtual CaptureRunReport RunSession(const std::filesystem::path& dir, CaptureRunnerOptions options,
                                      const CaptureStepDone& step_done) = 0;
};

}  // namespace mesocap::acquisition
