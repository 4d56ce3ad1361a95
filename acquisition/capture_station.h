// The rig a capture daemon holds open: its devices, built once from a rig
// description and kept between sessions, and how a session of each plan
// kind is started on it. A real rig and the simulated one (whose scene is
// the sample on the turntable) are both stations; the daemon sees only this.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "acquisition/capture_session_runner.h"
#include "drivers/rig.h"

namespace mesocap::acquisition {

// One device's state as the rig status reports it.
struct DeviceState {
  std::string device;  // "camera cam0", "turntable", "light arc", "lamps", "laser"
  std::string state;   // what it reads, e.g. "at 30.00 deg, homed"
};

class CaptureStation {
 public:
  virtual ~CaptureStation() = default;

  virtual std::string rig_name() const = 0;
  // The plan kinds OpenSession takes ("capture", "calibration").
  virtual std::vector<std::string> plan_kinds() const = 0;
  // Creates the session of `plan_kind` at `dir` (a folder that does not
  // exist yet, or one whose creation was interrupted); when `dir` already
  // holds a session, checks that it records the same capture on this rig.
  // Throws Error naming what differs.
  virtual void OpenSession(const std::filesystem::path& dir, const std::string& plan_kind) = 0;
  // Runs the session at `dir` through RunCaptureSession on the station's
  // devices, with the station's calibration for sweep analyses.
  virtual CaptureRunReport RunSession(const std::filesystem::path& dir, CaptureRunnerOptions options,
                                      const CaptureStepDone& step_done) = 0;
  // Reads every device's state. Called only from the thread that runs
  // sessions (devices are not shared between threads).
  virtual std::vector<DeviceState> ReadDeviceStates() = 0;
};

// The states of a rig's devices, read through the drivers/ interfaces.
std::vector<DeviceState> ReadRigDeviceStates(const drivers::Rig& rig);

}  // namespace mesocap::acquisition
