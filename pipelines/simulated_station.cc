#include "pipelines/simulated_station.h"

#include <spdlog/spdlog.h>

#include <nlohmann/json.hpp>
#include <vector>

#include "acquisition/capture_plan.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/file_checksum.h"
#include "core/json_field_reader.h"
#include "drivers/aravis/aravis_rig_backend.h"
#include "formats/capture_session.h"
#include "pipelines/station_session.h"
#include "sim/camera_renderer.h"
#include "sim/fault_plan.h"
#include "sim/served_cameras.h"
#include "sim/shipped_rigs.h"
#include "sim/simulated_devices.h"
#include "sim/simulated_operator.h"
#include "sim/simulated_rig_backend.h"
#include "sim/true_calibration.h"

namespace mesocap::pipelines {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

sim::FaultPlan LoadFaults(const formats::RigDescription& rig, const SimulatedStationOptions& o) {
  sim::FaultPlan faults = sim::FaultPlanOfRig(rig);
  if (!o.faults.empty()) {
    const sim::FaultPlan extra = sim::ReadFaultPlan(o.faults);
    faults.rules.insert(faults.rules.end(), extra.rules.begin(), extra.rules.end());
  }
  core::ThrowIfInvalid(faults.Check(rig), o.faults.empty() ? o.rig : o.faults.string());
  return faults;
}

sim::CameraRendererOptions RendererOptions(const SimulatedStationOptions& o) {
  sim::CameraRendererOptions r;
  r.samples_per_pixel_side = o.samples_per_pixel_side;
  r.interreflection_rays_per_pixel = o.interreflection_rays;
  return r;
}

}  // namespace

core::CheckResult SimulatedStationOptions::Check() const {
  if (rig.empty()) return "rig must name a shipped rig or a rig description file";
  if (samples_per_pixel_side < 1 || samples_per_pixel_side > 16) return "samples_per_pixel_side must be 1..16";
  if (interreflection_rays < 0 || interreflection_rays > 256) return "interreflection_rays must be 0..256";
  return {};
}

// Declared in the order they are built: the renderer outlives the cameras
// the backend makes, the served cameras outlive the Aravis devices.
struct SimulatedStation::Devices {
  std::unique_ptr<sim::MesostructureScene> scene;
  formats::RigDescription rig;
  sim::FaultPlan faults;
  formats::Calibration calibration;
  std::string calibration_text;
  core::FileChecksum calibration_checksum;
  json recording;
  sim::CameraRenderer renderer;
  sim::SimulatedRigBackend backend;
  std::unique_ptr<sim::ServedCameras> served;
  drivers::aravis::AravisRigBackend aravis;
  drivers::Rig devices;
  sim::SimulatedOperator rig_operator;

  Devices(std::unique_ptr<sim::MesostructureScene> scene_in, formats::RigDescription rig_in,
          const SimulatedStationOptions& o)
      : scene(std::move(scene_in)),
        rig(std::move(rig_in)),
        faults(LoadFaults(rig, o)),
        calibration(sim::TrueCalibration(rig)),
        calibration_text(formats::CalibrationText(calibration)),
        calibration_checksum(core::ComputeChecksum(calibration_text)),
        // What shaped the data beyond the rig; faults are left out, since
        // they change how long a capture takes, not what it records.
        recording({{"simulated_scene", scene->name()},
                   {"seed", o.seed},
                   {"sensor_noise", !o.no_noise},
                   {"samples_per_pixel_side", o.samples_per_pixel_side},
                   {"interreflection_rays_per_pixel", o.interreflection_rays}}),
        // The renderer refuses a scene the rig cannot hold (its backing
        // board too close below the mesostructure) before anything is written.
        renderer(*scene, rig, RendererOptions(o)),
        backend(renderer, faults, o.seed, o.no_noise ? sim::SensorModel::kNoiseless : sim::SensorModel::kNoisy),
        devices(BuildDevices(o)),
        rig_operator(backend.shared_state()) {}

  drivers::Rig BuildDevices(const SimulatedStationOptions& o) {
    formats::RigDescription device_rig = rig;
    if (o.serve_cameras) {
      served = sim::ServeRigCameras(rig, backend);
      for (std::size_t i = 0; i < served->size(); ++i) {
        device_rig.cameras[i].backend = "aravis";
        device_rig.cameras[i].device = served->address(i).address;
        spdlog::info("serving camera {} as a GigE Vision device at {}", rig.cameras[i].id, served->address(i).address);
      }
    }
    drivers::Rig built = drivers::BuildRig(device_rig, {{"sim", &backend}, {"aravis", &aravis}});
    built.description = rig;
    return built;
  }
};

SimulatedStation::SimulatedStation(const SimulatedStationOptions& options) : options_(options) {
  core::ThrowIfInvalid(options_.Check(), "simulated rig");
  devices_ = std::make_unique<Devices>(sim::LoadScene(options_.scene), sim::LoadRig(options_.rig), options_);
}

SimulatedStation::~SimulatedStation() = default;

std::string SimulatedStation::rig_name() const { return devices_->rig.name; }
std::string SimulatedStation::scene_name() const { return devices_->scene->name(); }
bool SimulatedStation::has_faults() const { return !devices_->faults.empty(); }
double SimulatedStation::rig_clock_s() const { return devices_->backend.state().clock_s; }

void SimulatedStation::OpenSession(const fs::path& dir, const std::string& plan_kind) {
  const Devices& d = *devices_;
  OpenStationSession(dir, {d.rig.json, acquisition::MakePlanOfKind(d.rig, plan_kind, d.recording), d.calibration_text,
                           d.calibration_checksum, "this rig's true one"});
}

sim::ServedCameras* SimulatedStation::served_cameras() { return devices_->served.get(); }

void SimulatedStation::ReplaceLamp(int index) {
  auto* lamps = dynamic_cast<sim::SimulatedLampBank*>(devices_->devices.lamps.get());
  if (lamps == nullptr) throw core::Error("lamp " + std::to_string(index) + ": the lamps are not simulated");
  lamps->ReplaceLamp(index);
}

std::vector<std::string> SimulatedStation::camera_ids() const { return devices_->rig.camera_ids(); }

std::vector<drivers::DeviceState> SimulatedStation::DeviceStates() {
  drivers::aravis::ReopenGoneCameras(devices_->devices);
  return drivers::ReadDeviceStates(devices_->devices);
}

acquisition::CaptureRunReport SimulatedStation::RunSession(const fs::path& dir,
                                                           acquisition::CaptureRunnerOptions options,
                                                           const acquisition::CaptureStepDone& step_done) {
  options.calibration = &devices_->calibration;  // for sweeps the rig analyses as they are captured
  return acquisition::RunCaptureSession(dir, devices_->devices, devices_->rig_operator, options, step_done);
}

}  // namespace mesocap::pipelines
