// `mesocap simulate --scene S --rig R --out SESSION [--seed N] [--no-noise]
// [--resume]`: a whole capture session as the simulated rig records it (MDF
// paper Sec. 3.1-3.2): BTF images (every turntable angle x light-arc angle x
// lamp, all cameras), the laser-plane calibration frames (the stripe at tilt
// 0 on flat plates at two heights, per laser location) and the laser sweeps
// (every turntable angle x laser location, all cameras).
//
// The session folder (core/capture_session.h) holds the manifest (rig
// snapshot, the true calibration as calibration.json, the plan: one step per
// group of files), the journal of completed steps and the data:
//   btf/t<ti>_a<ai>_l<lamp>_<cam>.png           16-bit RGB
//   laser_calibration/loc<li>_h<hi>_<cam>.png   16-bit grey
//   laser/t<ti>_loc<li>_<cam>.tif               16-bit grey frame sequence
// Pixel values are the sensor's codes / (2^bit_depth - 1).
//
// Work is shared as the images allow: per turntable angle and camera the
// first hits are traced once and lit by every lamp setting and laser sweep;
// a sweep frame costs only the stripe's Gaussian (sim/camera_renderer.h).
// Every image's noise is drawn from its own generator seeded by (seed, step,
// camera, frame), so a resumed session equals an uninterrupted one.
#include <spdlog/spdlog.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <string>
#include <vector>

#include "apps/mesocap/command.h"
#include "apps/mesocap/scene_option.h"
#include "core/capture_journal.h"
#include "core/capture_session.h"
#include "core/error.h"
#include "core/frame_sequence.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "sim/camera_renderer.h"
#include "sim/camera_sensor.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
constexpr const char* kCalibrationFile = "calibration.json";

struct SimulateCommandOptions {
  SceneOption scene;
  std::string rig = "tiny";
  fs::path out;
  std::uint64_t seed = 1;
  bool no_noise = false;
  bool resume = false;
  int samples_per_pixel_side = 3;
};

// Rounded so that the plan is byte-identical across runs and machines (it is
// compared on --resume).
double Degrees(double rad) { return std::round(rad * kDegPerRad * 1e9) / 1e9; }

json CameraFiles(const drivers::RigDescription& rig, const std::string& stem, const std::string& extension) {
  json files = json::array();
  for (const auto& cam : rig.cameras) files.push_back({{"camera", cam.id}, {"path", stem + "_" + cam.id + extension}});
  return files;
}

// The session's plan, in the order the rig executes it: the laser-plane
// calibration first (Sec. 3.2 computes the plane angle before scanning),
// then per turntable angle the BTF images and the sweeps.
std::vector<PlannedStep> MakePlan(const drivers::RigDescription& rig, const std::string& scene,
                                  const SimulateCommandOptions& o) {
  const json simulation = {{"scene", scene}, {"seed", o.seed}, {"sensor_noise", !o.no_noise},
                           {"samples_per_pixel_side", o.samples_per_pixel_side}};
  std::vector<PlannedStep> plan;
  const auto& laser = rig.laser;
  for (std::size_t li = 0; li < laser.locations.size(); ++li) {
    const auto& loc = laser.locations[li];
    for (int hi = 0; hi < 2; ++hi) {
      const std::string stem = "loc" + std::to_string(li) + "_h" + std::to_string(hi);
      plan.push_back({"laser-calibration-" + stem, StepKind::kLaserCalibration,
                      {{"location", li},
                       {"mount", loc.mount},
                       {"arc_deg", Degrees(loc.arc_angle_rad)},
                       {"height_mm", laser.calibration_heights_mm[hi]},
                       {"tilt_deg", 0.0},
                       {"files", CameraFiles(rig, "laser_calibration/" + stem, ".png")},
                       {"simulation", simulation}}});
    }
  }
  for (std::size_t ti = 0; ti < rig.turntable.angles_rad.size(); ++ti) {
    const double tt = rig.turntable.angles_rad[ti];
    for (std::size_t ai = 0; ai < rig.light_arc.angles_rad.size(); ++ai) {
      for (std::size_t lamp = 0; lamp < rig.lamps.elevations_rad.size(); ++lamp) {
        const std::string stem =
            "t" + std::to_string(ti) + "_a" + std::to_string(ai) + "_l" + std::to_string(lamp);
        plan.push_back({"btf-" + stem, StepKind::kBtfImage,
                        {{"turntable_index", ti},
                         {"turntable_deg", Degrees(tt)},
                         {"arc_index", ai},
                         {"arc_deg", Degrees(rig.light_arc.angles_rad[ai])},
                         {"lamp", lamp},
                         {"lamp_elevation_deg", Degrees(rig.lamps.elevations_rad[lamp])},
                         {"files", CameraFiles(rig, "btf/" + stem, ".png")},
                         {"simulation", simulation}}});
      }
    }
    for (std::size_t li = 0; li < laser.locations.size(); ++li) {
      const auto& loc = laser.locations[li];
      json offsets = json::array();
      json tilts = json::array();
      for (int f = 0; f < laser.frames_per_sweep; ++f) {
        const double offset =
            laser.sweep_min_mm + (laser.sweep_max_mm - laser.sweep_min_mm) * f / (laser.frames_per_sweep - 1);
        offsets.push_back(std::round(offset * 1e9) / 1e9);
        tilts.push_back(Degrees(drivers::LaserTiltForOffset(laser, loc.mount, offset)));
      }
      const std::string stem = "t" + std::to_string(ti) + "_loc" + std::to_string(li);
      plan.push_back({"laser-sweep-" + stem, StepKind::kLaserSweep,
                      {{"turntable_index", ti},
                       {"turntable_deg", Degrees(tt)},
                       {"location", li},
                       {"mount", loc.mount},
                       {"arc_deg", Degrees(loc.arc_angle_rad)},
                       {"offset_mm", offsets},
                       {"tilt_deg", tilts},
                       {"files", CameraFiles(rig, "laser/" + stem, ".tif")},
                       {"simulation", simulation}}});
    }
  }
  return plan;
}

// Runs the plan, journaling each step once all its files are on disk.
class SessionRecorder {
 public:
  SessionRecorder(const fs::path& dir, const SessionManifest& manifest, const sim::CameraRenderer& renderer,
                  const SimulateCommandOptions& o)
      : dir_(dir),
        manifest_(manifest),
        renderer_(renderer),
        rig_(renderer.rig()),
        options_(o),
        journal_(dir / kSessionJournalName, &manifest_),
        progress_("simulate " + manifest.rig.value("name", std::string()), manifest.plan.size()) {
    done_at_start_ = journal_.records().size();
    for (std::size_t i = 0; i < manifest_.plan.size(); ++i) {
      step_index_[manifest_.plan[i].id] = i;
      if (journal_.IsDone(manifest_.plan[i].id)) progress_.Advance();
    }
  }

  void Run() {
    for (const auto& step : manifest_.plan) {
      if (step.kind == StepKind::kLaserCalibration && !journal_.IsDone(step.id)) RecordCalibration(step);
    }
    for (std::size_t ti = 0; ti < rig_.turntable.angles_rad.size(); ++ti) RecordTurntableAngle(ti);
    progress_.Finish();
  }

  // Steps already journaled when the recorder opened the session.
  std::size_t done_at_start() const { return done_at_start_; }

 private:
  Image Sense(const Image& signal, const PlannedStep& step, int camera, int frame) const {
    std::mt19937_64 rng = sim::ImageNoiseGenerator(options_.seed, {step_index_.at(step.id),
                                                                   static_cast<std::uint64_t>(camera),
                                                                   static_cast<std::uint64_t>(frame)});
    return sim::ApplySensor(signal, rig_.cameras[camera], rng, !options_.no_noise);
  }

  fs::path FilePath(const PlannedStep& step, int camera) const {
    const fs::path path = dir_ / step.params.at("files").at(camera).at("path").get<std::string>();
    fs::create_directories(path.parent_path());
    return path;
  }

  void Journal(const PlannedStep& step) {
    JournalRecord record;
    record.seq = journal_.next_seq();
    record.step = step.id;
    record.time_utc = UtcTimestamp(std::chrono::system_clock::now());
    for (const auto& f : step.params.at("files")) {
      const std::string path = f.at("path").get<std::string>();
      record.files.push_back({path, fs::file_size(dir_ / path)});
    }
    journal_.Append(record);
    progress_.Advance();
  }

  void RecordCalibration(const PlannedStep& step) {
    const int mount = step.params.at("mount").get<int>();
    const double arc = step.params.at("arc_deg").get<double>() / kDegPerRad;
    const double height = step.params.at("height_mm").get<double>();
    for (int cam = 0; cam < static_cast<int>(rig_.cameras.size()); ++cam) {
      const sim::CameraView plate = renderer_.TracePlate(cam, height);
      const Image stripe = sim::LaserSweepRenderer(renderer_, plate, mount, arc).Frame(0.0);
      WriteImage(FilePath(step, cam), Sense(stripe, step, cam, 0), PixelEncoding::kUInt16);
    }
    Journal(step);
  }

  // All steps at one turntable angle share the traced first hits of each
  // camera: trace once per camera, then write every pending step's image of
  // that camera.
  void RecordTurntableAngle(std::size_t ti) {
    std::vector<const PlannedStep*> pending;
    for (const auto& step : manifest_.plan) {
      if (step.kind == StepKind::kLaserCalibration) continue;
      if (step.params.at("turntable_index").get<std::size_t>() != ti) continue;
      if (!journal_.IsDone(step.id)) pending.push_back(&step);
    }
    if (pending.empty()) return;
    const double tt = rig_.turntable.angles_rad[ti];
    for (int cam = 0; cam < static_cast<int>(rig_.cameras.size()); ++cam) {
      const sim::CameraView view = renderer_.TraceSample(cam, tt);
      for (const PlannedStep* step : pending) {
        if (step->kind == StepKind::kBtfImage) {
          std::vector<bool> lamps_on(rig_.lamps.elevations_rad.size(), false);
          lamps_on.at(step->params.at("lamp").get<std::size_t>()) = true;
          const double arc = rig_.light_arc.angles_rad.at(step->params.at("arc_index").get<std::size_t>());
          WriteImage(FilePath(*step, cam), Sense(renderer_.RenderLamps(view, arc, lamps_on), *step, cam, 0),
                     PixelEncoding::kUInt16);
        } else {
          RecordSweep(*step, view, cam);
        }
      }
    }
    for (const PlannedStep* step : pending) Journal(*step);
  }

  void RecordSweep(const PlannedStep& step, const sim::CameraView& view, int cam) {
    const auto& loc = rig_.laser.locations.at(step.params.at("location").get<std::size_t>());
    const sim::LaserSweepRenderer sweep(renderer_, view, loc.mount, loc.arc_angle_rad);
    FrameSequenceWriter writer(FilePath(step, cam), view.width, view.height, 1, PixelEncoding::kUInt16);
    const json& tilts = step.params.at("tilt_deg");
    for (int f = 0; f < static_cast<int>(tilts.size()); ++f) {
      writer.Append(Sense(sweep.Frame(tilts[f].get<double>() / kDegPerRad), step, cam, f));
    }
    writer.Commit();
  }

  fs::path dir_;
  SessionManifest manifest_;
  const sim::CameraRenderer& renderer_;
  const drivers::RigDescription& rig_;
  SimulateCommandOptions options_;
  CaptureJournal journal_;
  Progress progress_;
  std::map<std::string, std::uint64_t> step_index_;
  std::size_t done_at_start_ = 0;
};

json PlanJson(const std::vector<PlannedStep>& plan) {
  SessionManifest m;
  m.rig = {{"name", "-"}};
  m.plan = plan;
  return ToJson(m).at("plan");
}

void RunSimulate(const SimulateCommandOptions& o) {
  const auto scene = o.scene.Load();
  const drivers::RigDescription rig = sim::LoadRig(o.rig);
  const Calibration calibration = sim::TrueCalibration(rig);
  const std::vector<PlannedStep> plan = MakePlan(rig, scene->name(), o);

  const bool existing = fs::exists(o.out / kSessionManifestName);
  if (existing && !o.resume) {
    throw Error(o.out.string() + ": already holds a capture session; use --resume to complete it");
  }
  SessionManifest manifest;
  if (existing) {
    manifest = ReadSessionManifest(o.out);
    // A resumed session must be the same capture: same rig, scene, seed,
    // noise and sampling (all in the plan's step params).
    if (manifest.rig != rig.json || PlanJson(manifest.plan) != PlanJson(plan)) {
      throw Error(o.out.string() + ": the session was started with a different rig, scene, seed or options");
    }
  } else {
    manifest.rig = rig.json;
    manifest.calibration = kCalibrationFile;
    manifest.plan = plan;
    CreateCaptureSession(o.out, manifest);
    manifest = ReadSessionManifest(o.out);
  }
  if (!fs::exists(o.out / kCalibrationFile)) WriteCalibration(o.out / kCalibrationFile, calibration);

  sim::CameraRendererOptions render_options;
  render_options.samples_per_pixel_side = o.samples_per_pixel_side;
  const sim::CameraRenderer renderer(*scene, rig, render_options);
  spdlog::info("simulating scene {} on rig {}: {} steps{}", scene->name(), rig.name, plan.size(),
               o.no_noise ? ", no sensor noise" : "");
  SessionRecorder recorder(o.out, manifest, renderer, o);
  if (recorder.done_at_start() > 0) spdlog::info("resuming: {} steps already done", recorder.done_at_start());
  recorder.Run();
  spdlog::info("wrote {}", o.out.string());
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
  sub->add_option("--seed", o->seed, "seed of the sensor noise")->capture_default_str();
  sub->add_flag("--no-noise", o->no_noise, "no shot or read noise (quantization and saturation remain)");
  sub->add_flag("--resume", o->resume, "complete an interrupted session at --out, skipping journaled steps");
  sub->add_option("--samples-per-pixel-side", o->samples_per_pixel_side,
                  "rays per pixel side (box-filtered pixel area)")
      ->check(CLI::Range(1, 16))
      ->capture_default_str();
  sub->callback([o] { RunSimulate(*o); });
}

}  // namespace mesocap
