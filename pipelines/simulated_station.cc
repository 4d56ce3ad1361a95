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
#include "sim/camera_renderer.h"
#include "sim/fault_plan.h"
#include "sim/served_cameras.h"
#include "sim/shipped_rigs.h"
#include "sim/simulated_operator.h"
#include "sim/simulated_rig_backend.h"
#include "sim/true_calibration.h"

namespace mesocap::pipelines {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kCalibrationFile = "calibration.json";

// Where `old` and `now` first differ, as "FIELD was X, now Y" (FIELD a path
// such as "cameras[0].bit_depth" below `where`).
std::string FirstDifference(const json& old, const json& now, const std::string& where) {
  const json patch = json::diff(old, now);
  if (patch.empty()) return where + " is the same";
  const json::json_pointer pointer(patch[0].at("path").get<std::string>());
  std::vector<std::string> parts;
  for (json::json_pointer p = pointer; !p.empty(); p = p.parent_pointer()) parts.push_back(p.back());
  std::string field = where;
  for (auto part = parts.rbegin(); part != parts.rend(); ++part) {
    const bool index = !part->empty() && part->find_first_not_of("0123456789") == std::string::npos;
    field += index ? "[" + *part + "]" : "." + *part;
  }
  const auto value = [&](const json& document) {
    return document.contains(pointer) ? core::JsonExcerpt(document.at(pointer)) : std::string("absent");
  };
  return core::Cut(field) + " was " + value(old) + ", now " + value(now);
}

json PlanJson(const std::vector<formats::PlannedStep>& plan) {
  formats::SessionManifest m;
  m.rig = {{"name", "-"}};
  m.plan = plan;
  return ToJson(m).at("plan");
}

sim::FaultPlan LoadFaults(const formats::RigDescription& rig, const SimulatedStationOptions& o) {
  sim::FaultPlan faults = sim::FaultPlanOfRig(rig);
  if (!o.faults.empty()) {
    const sim::FaultPlan extra = sim::ReadFaultPlan(o.faults);
    faults.rules.insert(faults.rules.end(), extra.rules.begin(), extra.rules.end());
  }
  if (const core::CheckResult problem = faults.Check(rig); !problem.empty()) {
    throw core::Error((o.faults.empty() ? o.rig : o.faults.string()) + ": " + problem);
  }
  return faults;
}

sim::CameraRendererOptions RendererOptions(const SimulatedStationOptions& o) {
  sim::CameraRendererOptions r;
  r.samples_per_pixel_side = o.samples_per_pixel_side;
  r.interreflection_rays_per_pixel = o.interreflection_rays;
  return r;
}

}  // namespace

std::string SimulatedStationOptions::Check() const {
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
  if (const std::string problem = options_.Check(); !problem.empty()) throw core::Error("simulated rig: " + problem);
  devices_ = std::make_unique<Devices>(sim::LoadScene(options_.scene), sim::LoadRig(options_.rig), options_);
}

SimulatedStation::~SimulatedStation() = default;

std::string SimulatedStation::rig_name() const { return devices_->rig.name; }
std::string SimulatedStation::scene_name() const { return devices_->scene->name(); }
bool SimulatedStation::has_faults() const { return !devices_->faults.empty(); }
double SimulatedStation::rig_clock_s() const { return devices_->backend.state().clock_s; }

void SimulatedStation::OpenSession(const fs::path& dir, const std::string& plan_kind) {
  Devices& d = *devices_;
  std::vector<formats::PlannedStep> plan;
  if (plan_kind == "capture") {
    plan = acquisition::MakeCapturePlan(d.rig, d.recording);
  } else if (plan_kind == "calibration") {
    plan = acquisition::MakeCalibrationPlan(d.rig, d.recording);
  } else {
    throw core::Error("plan kind " + core::Quoted(plan_kind) + ": expected \"capture\" or \"calibration\"");
  }
  const bool existing = fs::exists(dir / formats::kSessionManifestName);
  if (existing) {
    const formats::SessionManifest manifest = formats::ReadSessionManifest(dir);
    // A resumed session must be the same capture: same rig, scene, seed,
    // noise and sampling (all in the plan's step params).
    if (manifest.rig != d.rig.json) {
      throw core::Error(dir.string() + ": the session was started with another rig: " +
                        FirstDifference(manifest.rig, d.rig.json, "rig"));
    }
    const json old_plan = PlanJson(manifest.plan), new_plan = PlanJson(plan);
    if (old_plan != new_plan) {
      // The options live in each step's "recording"; name them as such.
      const json old_recording = old_plan.at("steps").at(0).value("recording", json());
      const json new_recording = new_plan.at("steps").at(0).value("recording", json());
      throw core::Error(dir.string() + ": the session was started with other options: " +
                        (old_recording != new_recording ? FirstDifference(old_recording, new_recording, "recording")
                                                        : FirstDifference(old_plan, new_plan, "plan")));
    }
    if (manifest.calibration_checksum && *manifest.calibration_checksum != d.calibration_checksum) {
      throw core::Error(dir.string() + ": the session records another calibration than this rig's true one (" +
                        formats::kSessionManifestName + " calibration.xxh3_64)");
    }
  } else {
    // A folder without a manifest is a session whose creation was killed:
    // CreateCaptureSession clears what that run left.
    formats::SessionManifest manifest;
    manifest.rig = d.rig.json;
    manifest.calibration = kCalibrationFile;
    manifest.calibration_checksum = d.calibration_checksum;
    manifest.plan = plan;
    formats::CreateCaptureSession(dir, manifest);
  }
  // The session's calibration is the rig's true one: written after the
  // manifest, and written again when a resume finds it missing or damaged.
  if (const std::string problem = core::ChecksumProblem(dir / kCalibrationFile, d.calibration_checksum);
      !problem.empty()) {
    if (existing) spdlog::warn("{}: {} {}; writing it again", dir.string(), kCalibrationFile, problem);
    core::WriteTextFileAtomically(dir / kCalibrationFile, d.calibration_text);
  }
}

acquisition::CaptureRunReport SimulatedStation::RunSession(const fs::path& dir,
                                                           acquisition::CaptureRunnerOptions options,
                                                           const acquisition::CaptureStepDone& step_done) {
  options.calibration = &devices_->calibration;  // for sweeps the rig analyses as they are captured
  return acquisition::RunCaptureSession(dir, devices_->devices, devices_->rig_operator, options, step_done);
}

}  // namespace mesocap::pipelines
