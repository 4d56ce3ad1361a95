// The simulated rig as a capture station (acquisition/capture_station.h):
// the scene is the sample on the turntable, the rig description's devices
// are the simulated ones (sim/simulated_devices.h), the operator is the
// simulated one, and the calibration that sweep analyses use is the rig's
// true one. `mesocap simulate` runs one session on it; `mesocapd` keeps it
// open and runs a queue of them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "acquisition/capture_station.h"
#include "core/error.h"
#include "sim/mesostructure_scene.h"
#include "sim/served_cameras.h"

namespace mesocap::pipelines {

struct SimulatedStationOptions {
  sim::SceneSource scene;
  std::string rig = "tiny";  // a shipped rig or a rig description file
  std::uint64_t seed = 1;
  bool no_noise = false;
  std::filesystem::path faults;  // fault plan added to the rig's own ("": none)
  // Serve the simulated cameras as GigE Vision devices on loopback and
  // drive them through the Aravis backend, as a real rig's cameras are.
  bool serve_cameras = false;
  int samples_per_pixel_side = 3;
  int interreflection_rays = 0;

  core::CheckResult Check() const;
};

class SimulatedStation : public acquisition::CaptureStation {
 public:
  // Loads the scene and rig and builds every device. Throws Error naming
  // the rig or fault file when they are wrong, before anything is written.
  explicit SimulatedStation(const SimulatedStationOptions& options);
  ~SimulatedStation() override;

  std::string rig_name() const override;
  void OpenSession(const std::filesystem::path& dir, const std::string& plan_kind) override;
  std::vector<std::string> camera_ids() const override;
  // Served cameras (`serve_cameras`) that stopped answering are reopened
  // through Aravis when their server is back.
  std::vector<drivers::DeviceState> DeviceStates() override;
  acquisition::CaptureRunReport RunSession(const std::filesystem::path& dir, acquisition::CaptureRunnerOptions options,
                                           const acquisition::CaptureStepDone& step_done) override;

  // The scene's name, whether faults are planned, and the rig's simulated
  // clock (seconds of rig time so far), for the log.
  std::string scene_name() const;
  bool has_faults() const;
  double rig_clock_s() const;

  // What the person at the rig does about faults: the cameras' GigE Vision
  // servers (nullptr without serve_cameras: a test stops and restarts
  // them), and a new bulb for a burnt-out lamp. Not while a session runs.
  sim::ServedCameras* served_cameras();
  void ReplaceLamp(int index);

 private:
  struct Devices;
  SimulatedStationOptions options_;
  std::unique_ptr<Devices> devices_;
};

}  // namespace mesocap::pipelines
