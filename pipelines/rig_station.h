// A real rig as a capture station (acquisition/capture_station.h): every
// device of the rig description opened through the backend it names
// (cameras through Aravis, stages on Pololu Tics, lamps and laser on GPIO
// lines) and kept open; the rig's calibration from a file (`mesocap
// calibrate --session`), written into each session and used for the sweeps
// the rig analyses as they arrive. What no motor does (plates, laser mounts,
// board tilts) is done by a person: a session runs only with an operator
// prompt (the daemon's --prompt-operator), and the acknowledgement is all
// there is to do in code.
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "acquisition/capture_station.h"
#include "core/error.h"
#include "drivers/rig.h"
#include "formats/calibration.h"

namespace mesocap::pipelines {

struct RigStationOptions {
  std::filesystem::path rig;          // a rig description file whose devices are real
  std::filesystem::path calibration;  // the rig's calibration.json

  core::CheckResult Check() const;
};

// Whether a rig description drives any real device (a backend other than
// "sim" for a stage, the lamps or the laser): such a rig is a RigStation's,
// an all-simulated one a SimulatedStation's.
bool DrivesRealDevices(const formats::RigDescription& rig);

class RigStation : public acquisition::CaptureStation {
 public:
  // Opens every device with `backends` (by their names; the real ones when
  // empty: aravis, tic over libusb, gpiod over libgpiod). Throws Error
  // naming the rig file, the calibration file or the device that fails.
  explicit RigStation(const RigStationOptions& options,
                      std::vector<std::unique_ptr<drivers::RigBackend>> backends = {});
  ~RigStation() override;

  std::string rig_name() const override;
  std::vector<std::string> camera_ids() const override;
  // Aravis cameras that stopped answering are reopened when they answer again.
  std::vector<drivers::DeviceState> DeviceStates() override;
  void OpenSession(const std::filesystem::path& dir, const std::string& plan_kind) override;
  // Throws Error before anything moves when `options` has no operator prompt.
  acquisition::CaptureRunReport RunSession(const std::filesystem::path& dir, acquisition::CaptureRunnerOptions options,
                                           const acquisition::CaptureStepDone& step_done) override;

 private:
  formats::RigDescription description_;
  formats::Calibration calibration_;
  std::string calibration_text_;
  core::FileChecksum calibration_checksum_;
  std::vector<std::unique_ptr<drivers::RigBackend>> backends_;
  drivers::Rig rig_;
};

}  // namespace mesocap::pipelines
