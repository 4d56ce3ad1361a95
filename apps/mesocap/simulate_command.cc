// `mesocap simulate --scene S --rig R --out SESSION [--plan capture|btf|calibration]
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

#include "acquisition/capture_plan.h"
#include "acquisition/capture_session_runner.h"
#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "apps/mesocap/scene_option.h"
#include "core/error.h"
#include "formats/capture_session.h"
#include "pipelines/simulated_station.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;

struct SimulateCommandOptions {
  pipelines::SimulatedStationOptions station;
  fs::path out;
  bool resume = false;
  std::string plan = "capture";  // or "btf", "calibration"
};

// The command line that resumes the session these options record.
std::string ResumeCommand(const SimulateCommandOptions& c) {
  const pipelines::SimulatedStationOptions& o = c.station;
  const auto arg = [](const std::string& text) {
    return text.find_first_of(" '\"\\$`") == std::string::npos ? text : "'" + text + "'";
  };
  std::ostringstream line;
  line << "mesocap simulate --resume --out " << arg(c.out.string()) << " --scene " << arg(o.scene.scene);
  const sim::SceneSource defaults;
  if (o.scene.obj_scale != defaults.obj_scale) line << " --scale " << o.scene.obj_scale;
  if (o.scene.tile_size_mm != defaults.tile_size_mm) line << " --tile-size-mm " << o.scene.tile_size_mm;
  if (o.scene.depth_mm != defaults.depth_mm) line << " --depth-mm " << o.scene.depth_mm;
  line << " --rig " << arg(o.rig) << " --seed " << o.seed;
  if (c.plan != "capture") line << " --plan " << c.plan;
  if (o.no_noise) line << " --no-noise";
  if (!o.faults.empty()) line << " --faults " << arg(o.faults.string());
  line << " --samples-per-pixel-side " << o.samples_per_pixel_side << " --interreflection-rays "
       << o.interreflection_rays;
  return line.str();
}

void RunSimulate(const SimulateCommandOptions& o) {
  // Builds the rig (and checks scene, rig and faults) before anything is written.
  pipelines::SimulatedStation station(o.station);
  const bool existing = fs::exists(o.out / formats::kSessionManifestName);
  // A folder without a manifest is a session whose creation was killed:
  // resuming it starts it.
  if (!existing && o.resume && !fs::is_directory(o.out)) {
    throw core::Error(o.out.string() +
                      ": no capture session to resume (no such folder); leave out --resume to start "
                      "one");
  }
  if (existing && !o.resume) {
    throw core::Error(o.out.string() + ": already holds a capture session; use --resume to complete it");
  }
  station.OpenSession(o.out, o.plan);
  spdlog::info("simulating scene {} on rig {}{}{}", station.scene_name(), station.rig_name(),
               o.station.no_noise ? ", no sensor noise" : "", station.has_faults() ? ", with faults" : "");
  acquisition::CaptureRunnerOptions run_options;
  run_options.resume_command = ResumeCommand(o);
  const acquisition::CaptureRunReport report = station.RunSession(o.out, run_options, {});
  if (report.steps_done_before > 0) spdlog::info("resumed: {} steps were already done", report.steps_done_before);
  if (report.stale_temporaries_removed > 0) {
    spdlog::info("removed {} temporary files an interrupted run left", report.stale_temporaries_removed);
  }
  spdlog::info("wrote {}: {} steps, {} frames ({} dropped, {} operations retried), {:.0f} s of rig time",
               o.out.string(), report.steps_run, report.frames, report.dropped_frames, report.retries,
               station.rig_clock_s());
}

}  // namespace

void RegisterSimulateCommand(CLI::App& app) {
  auto o = std::make_shared<SimulateCommandOptions>();
  CLI::App* sub = app.add_subcommand("simulate", HelpText("simulate"));
  AddSceneOptions(sub, &o->station.scene);
  sub->add_option("--rig", o->station.rig, "shipped rig (tiny, small, paper) or a rig description file")
      ->capture_default_str();
  sub->add_option("--out", o->out, "capture session folder to create")->required();
  sub->add_option("--seed", o->station.seed, "seed of the sensor noise, 0..18446744073709551615")
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
  sub->add_flag("--no-noise", o->station.no_noise, "no shot or read noise (quantization and saturation remain)");
  sub->add_option("--faults", o->station.faults, "fault plan file (mesocap.faults) added to the rig's own faults");
  sub->add_flag("--resume", o->resume, "complete an interrupted session at --out, skipping journaled steps");
  sub->add_flag("--serve-cameras", o->station.serve_cameras,
                "serve the simulated cameras as GigE Vision devices on loopback and record them through Aravis "
                "(sim serve-cameras --help says where)");
  sub->add_option("--plan", o->plan,
                  "capture: BTF images, laser calibration and sweeps of the scene; btf: its BTF images alone; "
                  "calibration: the rig's calibration board on each holder tilt at each turntable angle (for "
                  "`mesocap calibrate`)")
      ->check(CLI::IsMember(acquisition::kPlanKinds))
      ->capture_default_str();
  sub->add_option("--samples-per-pixel-side", o->station.samples_per_pixel_side,
                  "rays per pixel side (box-filtered pixel area)")
      ->check(InRange(1, 16))
      ->capture_default_str();
  sub->add_option("--interreflection-rays", o->station.interreflection_rays,
                  "rays per pixel gathering the laser's light after one bounce (0: direct light only)")
      ->check(InRange(0, 256))
      ->capture_default_str();
  sub->callback([o] { RunSimulate(*o); });
}

}  // namespace mesocap
