#include "pipelines/rig_station.h"

#include "acquisition/capture_plan.h"
#include "core/error.h"
#include "core/file_checksum.h"
#include "drivers/aravis/aravis_rig_backend.h"
#include "drivers/gpiod/gpiod_rig_backend.h"
#include "drivers/tic/tic_rig_backend.h"
#include "pipelines/station_session.h"

namespace mesocap::pipelines {
namespace {

namespace fs = std::filesystem;

// The person at the rig: the prompt asked them, their acknowledgement says
// it is done, and nothing is left for code to do.
class PersonAtTheRig : public drivers::RigOperator {
 public:
  void PlaceCalibrationPlate(double) override {}
  void RemoveCalibrationPlate() override {}
  void MountLaser(int) override {}
  void PlaceCalibrationBoard(int, double) override {}
  void RemoveCalibrationBoard() override {}
  void PlaceWhiteReference(double) override {}
  void RemoveWhiteReference() override {}
  void PlaceMirrorSphere() override {}
  void RemoveMirrorSphere() override {}
};

std::vector<std::unique_ptr<drivers::RigBackend>> RealBackends() {
  std::vector<std::unique_ptr<drivers::RigBackend>> backends;
  backends.push_back(std::make_unique<drivers::aravis::AravisRigBackend>());
  backends.push_back(std::make_unique<drivers::tic::TicRigBackend>());
  backends.push_back(std::make_unique<drivers::gpiod::GpiodRigBackend>());
  return backends;
}

}  // namespace

core::CheckResult RigStationOptions::Check() const {
  if (rig.empty()) return "rig: expected a rig description file";
  if (calibration.empty()) {
    return "calibration: a real rig needs its calibration file (mesocap calibrate --session ... --out FILE)";
  }
  return {};
}

bool DrivesRealDevices(const formats::RigDescription& rig) {
  return rig.turntable.backend != "sim" || rig.light_arc.backend != "sim" || rig.lamps.backend != "sim" ||
         rig.laser.backend != "sim";
}

RigStation::RigStation(const RigStationOptions& options, std::vector<std::unique_ptr<drivers::RigBackend>> backends)
    : backends_(backends.empty() ? RealBackends() : std::move(backends)) {
  core::ThrowIfInvalid(options.Check(), "rig station");
  description_ = formats::ReadRigDescription(options.rig);
  if (!DrivesRealDevices(description_)) {
    throw core::Error(options.rig.string() + ": every device is simulated: run it as a simulated rig");
  }
  for (const formats::CameraDescription& c : description_.cameras) {
    if (c.backend == "sim") {
      throw core::Error(options.rig.string() + ": camera " + c.id +
                        " is simulated (\"backend\": \"sim\"), on a rig whose other devices are real");
    }
  }
  calibration_ = formats::ReadCalibration(options.calibration);
  calibration_text_ = formats::CalibrationText(calibration_);
  calibration_checksum_ = core::ComputeChecksum(calibration_text_);
  std::map<std::string, drivers::RigBackend*> by_name;
  for (const auto& b : backends_) by_name[b->name()] = b.get();
  rig_ = drivers::BuildRig(description_, by_name);
}

RigStation::~RigStation() = default;

std::string RigStation::rig_name() const { return description_.name; }

std::vector<std::string> RigStation::camera_ids() const { return description_.camera_ids(); }

std::vector<drivers::DeviceState> RigStation::DeviceStates() {
  drivers::aravis::ReopenGoneCameras(rig_);
  return drivers::ReadDeviceStates(rig_);
}

void RigStation::OpenSession(const fs::path& dir, const std::string& plan_kind) {
  OpenStationSession(dir, {description_.json, acquisition::MakePlanOfKind(description_, plan_kind), calibration_text_,
                           calibration_checksum_, "the one this rig was opened with"});
}

acquisition::CaptureRunReport RigStation::RunSession(const fs::path& dir, acquisition::CaptureRunnerOptions options,
                                                     const acquisition::CaptureStepDone& step_done) {
  if (!options.operator_prompt) {
    throw core::Error(dir.string() + ": rig " + description_.name +
                      ": its operator steps (plates, laser mounts, board tilts) need a person; run mesocapd with "
                      "--prompt-operator");
  }
  options.calibration = &calibration_;
  PersonAtTheRig person;
  return acquisition::RunCaptureSession(dir, rig_, person, options, step_done);
}

}  // namespace mesocap::pipelines
