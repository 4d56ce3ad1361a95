// `mesocap simulate --scene S --rig R --out SESSION [--plan capture|calibration]
// [--seed N] [--no-noise] [--faults FILE] [--resume]`: a whole capture
// session as the simulated rig records it (MDF paper Sec. 3.1-3.2), or with
// --plan calibration the rig's calibration session (acquisition/capture_plan.h). The capture plan
// (acquisition/capture_plan.h) is run by the same runner a real rig uses
// (acquisition/capture_session_runner.h), through the simulated devices
// (sim/simulated_devices.h): stages move, lamps switch, the laser tilts, the
// operator lays the calibration plates, cameras deliver noisy quantized
// frames, and faults happen as the rig description's "faults" member or
// --faults say.
//
// Work is shared as the images allow: the simulated cameras' renderer keeps
// each camera's traced first hits while the turntable stands still and a
// sweep's stripe samples while the laser stays put (sim/camera_renderer.h),
// so a sweep frame costs only the stripe's Gaussian. Each frame's noise is
// seeded by the state it images, so a resumed or fault-ridden session equals
// an uninterrupted one.
#include <spdlog/spdlog.h>

#include <charconv>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "acquisition/capture_plan.h"
#include "acquisition/capture_session_runner.h"
#include "apps/mesocap/command.h"
#include "apps/mesocap/scene_option.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/file_checksum.h"
#include "core/json_field_reader.h"
#include "drivers/aravis/aravis_rig_backend.h"
#include "drivers/rig.h"
#include "formats/capture_session.h"
#include "sim/camera_renderer.h"
#include "sim/fault_plan.h"
#include "sim/mesostructure_scene.h"
#include "sim/served_cameras.h"
#include "sim/shipped_rigs.h"
#include "sim/simulated_operator.h"
#include "sim/simulated_rig_backend.h"
#include "sim/true_calibration.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kCalibrationFile = "calibration.json";

struct SimulateCommandOptions {
  sim::SceneSource scene;
  std::string rig = "tiny";
  fs::path out;
  std::uint64_t seed = 1;
  bool no_noise = false;
  fs::path faults;
  bool resume = false;
  bool serve_cameras = false;
  int samples_per_pixel_side = 3;
  int interreflection_rays = 0;
  std::string plan = "capture";  // or "calibration"
};

// The command line that resumes the session these options record.
std::string ResumeCommand(const SimulateCommandOptions& o) {
  const auto arg = [](const std::string& text) {
    return text.find_first_of(" '\"\\$`") == std::string::npos ? text : "'" + text + "'";
  };
  std::ostringstream c;
  c << "mesocap simulate --resume --out " << arg(o.out.string()) << " --scene " << arg(o.scene.scene);
  const sim::SceneSource defaults;
  if (o.scene.obj_scale != defaults.obj_scale) c << " --scale " << o.scene.obj_scale;
  if (o.scene.tile_size_mm != defaults.tile_size_mm) c << " --tile-size-mm " << o.scene.tile_size_mm;
  if (o.scene.depth_mm != defaults.depth_mm) c << " --depth-mm " << o.scene.depth_mm;
  c << " --rig " << arg(o.rig) << " --seed " << o.seed;
  if (o.plan != "capture") c << " --plan " << o.plan;
  if (o.no_noise) c << " --no-noise";
  if (!o.faults.empty()) c << " --faults " << arg(o.faults.string());
  c << " --samples-per-pixel-side " << o.samples_per_pixel_side << " --interreflection-rays " << o.interreflection_rays;
  return c.str();
}

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

void RunSimulate(const SimulateCommandOptions& o) {
  const auto scene = sim::LoadScene(o.scene);
  const formats::RigDescription rig = sim::LoadRig(o.rig);
  sim::FaultPlan faults = sim::FaultPlanOfRig(rig);
  if (!o.faults.empty()) {
    const sim::FaultPlan extra = sim::ReadFaultPlan(o.faults);
    faults.rules.insert(faults.rules.end(), extra.rules.begin(), extra.rules.end());
  }
  if (const core::CheckResult problem = faults.Check(rig); !problem.empty()) {
    throw core::Error((o.faults.empty() ? o.rig : o.faults.string()) + ": " + problem);
  }
  const formats::Calibration calibration = sim::TrueCalibration(rig);
  // Before anything is written: the renderer refuses a scene the rig cannot
  // hold (its backing board too close below the mesostructure).
  sim::CameraRendererOptions render_options;
  render_options.samples_per_pixel_side = o.samples_per_pixel_side;
  render_options.interreflection_rays_per_pixel = o.interreflection_rays;
  sim::CameraRenderer renderer(*scene, rig, render_options);
  // What shaped the data beyond the rig; faults are left out, since they
  // change how long a capture takes, not what it records.
  const json recording = {{"simulated_scene", scene->name()},
                          {"seed", o.seed},
                          {"sensor_noise", !o.no_noise},
                          {"samples_per_pixel_side", o.samples_per_pixel_side},
                          {"interreflection_rays_per_pixel", o.interreflection_rays}};
  const std::vector<formats::PlannedStep> plan = o.plan == "calibration"
                                                     ? acquisition::MakeCalibrationPlan(rig, recording)
                                                     : acquisition::MakeCapturePlan(rig, recording);

  const std::string calibration_text = formats::CalibrationText(calibration);
  const core::FileChecksum calibration_checksum = core::ComputeChecksum(calibration_text);
  const bool existing = fs::exists(o.out / formats::kSessionManifestName);
  // A folder without a manifest is a session whose creation was killed:
  // resuming it starts it (CreateCaptureSession clears what that run left).
  if (!existing && o.resume && !fs::is_directory(o.out)) {
    throw core::Error(o.out.string() + ": no capture session to resume (no such folder); leave out --resume to start "
                      "one");
  }
  if (existing && !o.resume) {
    throw core::Error(o.out.string() + ": already holds a capture session; use --resume to complete it");
  }
  if (existing) {
    const formats::SessionManifest manifest = formats::ReadSessionManifest(o.out);
    // A resumed session must be the same capture: same rig, scene, seed,
    // noise and sampling (all in the plan's step params).
    if (manifest.rig != rig.json) {
      throw core::Error(o.out.string() + ": the session was started with another rig: " +
                        FirstDifference(manifest.rig, rig.json, "rig"));
    }
    const json old_plan = PlanJson(manifest.plan), new_plan = PlanJson(plan);
    if (old_plan != new_plan) {
      // The options live in each step's "recording"; name them as such.
      const json old_recording = old_plan.at("steps").at(0).value("recording", json());
      const json new_recording = new_plan.at("steps").at(0).value("recording", json());
      throw core::Error(o.out.string() + ": the session was started with other options: " +
                        (old_recording != new_recording ? FirstDifference(old_recording, new_recording, "recording")
                                                        : FirstDifference(old_plan, new_plan, "plan")));
    }
    if (manifest.calibration_checksum && *manifest.calibration_checksum != calibration_checksum) {
      throw core::Error(o.out.string() + ": the session records another calibration than this rig's true one (" +
                        formats::kSessionManifestName + " calibration.xxh3_64)");
    }
  } else {
    formats::SessionManifest manifest;
    manifest.rig = rig.json;
    manifest.calibration = kCalibrationFile;
    manifest.calibration_checksum = calibration_checksum;
    manifest.plan = plan;
    formats::CreateCaptureSession(o.out, manifest);
  }
  // The session's calibration is the rig's true one: written after the
  // manifest, and written again when a resume finds it missing or damaged.
  if (const std::string problem = core::ChecksumProblem(o.out / kCalibrationFile, calibration_checksum);
      !problem.empty()) {
    if (existing) spdlog::warn("{}: {} {}; writing it again", o.out.string(), kCalibrationFile, problem);
    core::WriteTextFileAtomically(o.out / kCalibrationFile, calibration_text);
  }

  sim::SimulatedRigBackend backend(renderer, faults, o.seed,
                                   o.no_noise ? sim::SensorModel::kNoiseless : sim::SensorModel::kNoisy);
  // With --serve-cameras every frame crosses loopback as GigE Vision: the
  // simulated cameras are served from this process and recorded through the
  // Aravis backend, as a real rig's cameras are.
  std::unique_ptr<sim::ServedCameras> served;
  formats::RigDescription device_rig = rig;
  if (o.serve_cameras) {
    served = sim::ServeRigCameras(rig, backend);
    for (std::size_t i = 0; i < served->size(); ++i) {
      device_rig.cameras[i].backend = "aravis";
      device_rig.cameras[i].device = served->address(i).address;
      spdlog::info("serving camera {} as a GigE Vision device at {}", rig.cameras[i].id, served->address(i).address);
    }
  }
  drivers::aravis::AravisRigBackend aravis;
  drivers::Rig devices = drivers::BuildRig(device_rig, {{"sim", &backend}, {"aravis", &aravis}});
  devices.description = rig;
  sim::SimulatedOperator rig_operator(backend.shared_state());
  spdlog::info("simulating scene {} on rig {}: {} steps{}{}", scene->name(), rig.name, plan.size(),
               o.no_noise ? ", no sensor noise" : "", faults.empty() ? "" : ", with faults");
  acquisition::CaptureRunnerOptions run_options;
  run_options.calibration = &calibration;  // for sweeps the rig analyses as they are captured
  run_options.resume_command = ResumeCommand(o);
  const acquisition::CaptureRunReport report =
      acquisition::RunCaptureSession(o.out, devices, rig_operator, run_options);
  if (report.steps_done_before > 0) spdlog::info("resumed: {} steps were already done", report.steps_done_before);
  if (report.stale_temporaries_removed > 0) {
    spdlog::info("removed {} temporary files an interrupted run left", report.stale_temporaries_removed);
  }
  spdlog::info("wrote {}: {} steps, {} frames ({} dropped, {} operations retried), {:.0f} s of rig time",
               o.out.string(), report.steps_run, report.frames, report.dropped_frames, report.retries,
               backend.state().clock_s);
}

}  // namespace

void RegisterSimulateCommand(CLI::App& app) {
  auto o = std::make_shared<SimulateCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "simulate", "Record a capture session (BTF images, laser calibration, laser sweeps) on the simulated rig");
  AddSceneOptions(sub, &o->scene);
  sub->add_option("--rig", o->rig, "shipped rig (tiny, small, paper) or a rig description file")
      ->capture_default_str();
  sub->add_option("--out", o->out, "capture session folder to create")->required();
  sub->add_option("--seed", o->seed, "seed of the sensor noise, 0..18446744073709551615")
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            std::uint64_t value = 0;
            const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
            if (ec != std::errc() || end != text.data() + text.size()) {
              return "expected an integer in [0, 18446744073709551615], got " + core::Quoted(text);
            }
            return {};
          },
          "an unsigned 64-bit integer"))
      ->capture_default_str();
  sub->add_flag("--no-noise", o->no_noise, "no shot or read noise (quantization and saturation remain)");
  sub->add_option("--faults", o->faults, "fault plan file (mesocap.faults) added to the rig's own faults");
  sub->add_flag("--resume", o->resume, "complete an interrupted session at --out, skipping journaled steps");
  sub->add_flag("--serve-cameras", o->serve_cameras,
                "serve the simulated cameras as GigE Vision devices on loopback and record them through Aravis "
                "(sim serve-cameras --help says where)");
  sub->add_option("--plan", o->plan,
                  "capture: BTF images, laser calibration and sweeps of the scene; calibration: the rig's "
                  "calibration board on each holder tilt at each turntable angle (for `mesocap calibrate`)")
      ->check(CLI::IsMember({"capture", "calibration"}))
      ->capture_default_str();
  sub->add_option("--samples-per-pixel-side", o->samples_per_pixel_side,
                  "rays per pixel side (box-filtered pixel area)")
      ->check(InRange(1, 16))
      ->capture_default_str();
  sub->add_option("--interreflection-rays", o->interreflection_rays,
                  "rays per pixel gathering the laser's light after one bounce (0: direct light only)")
      ->check(InRange(0, 256))
      ->capture_default_str();
  sub->callback([o] { RunSimulate(*o); });
}

}  // namespace mesocap
