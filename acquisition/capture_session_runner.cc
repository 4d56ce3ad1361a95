#include "acquisition/capture_session_runner.h"

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image.h"
#include "core/image_io.h"
#include "core/progress.h"
#include "drivers/device_error.h"
#include "formats/capture_journal.h"
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/captured_session.h"
#include "formats/frame_sequence.h"
#include "formats/sweep_analysis.h"
#include "mdf/laser_sweep.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;

// The frames a step takes: one a camera, each frame of a sweep.
std::uint64_t PlannedFrames(const formats::CaptureStep& step) {
  const std::uint64_t cameras = formats::Files(step).size();
  const auto* sweep = std::get_if<formats::LaserSweepStep>(&step);
  return sweep ? cameras * sweep->offsets_mm.size() : cameras;
}

class SessionRun {
 public:
  SessionRun(const fs::path& dir, drivers::Rig& rig, drivers::RigOperator& rig_operator,
             const CaptureRunnerOptions& options)
      : dir_(dir),
        manifest_(formats::ReadSessionManifest(dir)),
        rig_(rig),
        operator_(rig_operator),
        options_(options),
        journal_(dir / formats::kSessionJournalName, &manifest_) {
    if (!rig_.turntable || !rig_.light_arc || !rig_.lamps || !rig_.laser) {
      throw core::Error(dir_.string() + ": the rig lacks a turntable, light arc, lamp bank or laser unit");
    }
    for (std::size_t i = 0; i < rig_.cameras.size(); ++i) camera_index_[rig_.cameras[i]->info().id] = i;
    for (const formats::PlannedStep& step : manifest_.plan) {
      if (step.kind == formats::StepKind::kOther) {
        throw core::Error(dir_.string() + ": step \"" + step.id +
                          "\" is of kind \"other\", which a capture cannot run");
      }
    }
    const fs::path manifest_file = dir_ / formats::kSessionManifestName;
    rig_description_ = formats::ParseRigDescription(manifest_.rig, manifest_file);
    for (std::size_t s = 0; s < manifest_.plan.size(); ++s) {
      const formats::PlannedStep& step = manifest_.plan[s];
      steps_.push_back(formats::ReadCaptureStep(step, s, rig_description_, manifest_file));
      for (const formats::CameraFile& f : formats::Files(steps_.back())) CameraFor(step, f);
      const auto* sweep = std::get_if<formats::LaserSweepStep>(&steps_.back());
      if (sweep && sweep->stores_analysis && !options_.calibration) {
        throw core::Error(dir_.string() + ": step \"" + step.id +
                          "\" stores a sweep analysis, which needs the rig's calibration (none was given)");
      }
    }
    // A resumed session's finished steps must still hold what they captured:
    // a damaged file is captured again rather than processed later.
    for (const formats::DamagedFile& damaged : formats::DamagedSessionFiles(dir_, manifest_, journal_.records())) {
      if (damaged.step.empty() || !journal_.IsDone(damaged.step)) continue;
      spdlog::warn("{}: {} {}; capturing step {} again", dir_.string(), damaged.path, damaged.problem, damaged.step);
      journal_.Redo(damaged.step);
      ++report_.steps_redone;
    }
    for (std::size_t s = 0; s < manifest_.plan.size(); ++s) {
      if (!journal_.IsDone(manifest_.plan[s].id)) continue;
      ++report_.steps_done_before;
      report_.frames_done_before += PlannedFrames(steps_[s]);
    }
    report_.steps_total = manifest_.plan.size();
    // The journal's lock keeps other writers out, so what looks like a
    // temporary file was left by a writer that died.
    report_.stale_temporaries_removed = core::RemoveStaleTemporaries(dir_);
  }

  CaptureRunReport Run(const CaptureStepDone& step_done) {
    core::Progress progress("capture " + manifest_.rig.value("name", std::string()), manifest_.plan.size(),
                            options_.show_progress ? core::Progress::Style::kAuto : core::Progress::Style::kSilent);
    progress.Advance(report_.steps_done_before);
    // The step under way, or before the first, the first still to do.
    std::size_t s = 0;
    while (s < manifest_.plan.size() && journal_.IsDone(manifest_.plan[s].id)) ++s;
    try {
      for (auto& camera : rig_.cameras) camera->SetTrigger(drivers::TriggerMode::kSoftware);
      for (; s < manifest_.plan.size(); ++s) {
        const formats::PlannedStep& step = manifest_.plan[s];
        if (journal_.IsDone(step.id)) continue;
        if (options_.stop_before_step && options_.stop_before_step()) {
          report_.stopped = true;
          break;
        }
        RunStep(step, steps_[s]);
        Journal(step, steps_[s]);
        ++report_.steps_run;
        progress.Advance();
        if (step_done) step_done(report_, journal_.records().size());
      }
      AllOff();
      RemoveCalibrationPlate();
      RemoveBoard();
      RemoveWhiteReference();
      RemoveMirrorSphere();
    } catch (const drivers::DeviceError& e) {
      throw core::Error(Stopped(s, e.what()));
    } catch (const CaptureInterrupted&) {
      // Ended on purpose inside step s: it is done again on resume.
      try {
        AllOff();
      } catch (const drivers::DeviceError& e) {
        spdlog::warn("{}: switching lamps and laser off: {}", dir_.string(), e.what());
      }
      throw;
    } catch (const core::Error& e) {
      // Not the devices (out of memory, a full disk): the steps journaled are kept all the same.
      throw core::Error(Stopped(s, e.what()));
    }
    progress.Finish();
    return report_;
  }

 private:
  // The error line of a capture that device trouble stopped at step `s`:
  // where, why, what is kept, and how to go on.
  std::string Stopped(std::size_t s, const std::string& why) const {
    const std::size_t total = manifest_.plan.size();
    const std::string where = s < total ? "step \"" + manifest_.plan[s].id + "\" (" + std::to_string(s + 1) + " of " +
                                              std::to_string(total) + ")"
                                        : "after the last step";
    const std::string resume =
        options_.resume_command.empty() ? "run the capture again to resume" : "resume with: " + options_.resume_command;
    return dir_.string() + ": " + where + ": " + why + "; " + std::to_string(journal_.records().size()) + " of " +
           std::to_string(total) + " steps are journaled; " + resume;
  }

  double DescriptionExposure(const std::string& camera_id) const {
    for (const formats::CameraDescription& c : rig_description_.cameras) {
      if (c.id == camera_id) return c.exposure_us;
    }
    throw core::Error(dir_.string() + ": the session's rig has no camera " + core::Quoted(camera_id));
  }

  drivers::Camera& CameraFor(const formats::PlannedStep& step, const formats::CameraFile& file) {
    const auto it = camera_index_.find(file.camera);
    if (it == camera_index_.end()) {
      throw core::Error(dir_.string() + ": step \"" + step.id + "\" names camera " + core::Quoted(file.camera) +
                        ", which the rig lacks");
    }
    return *rig_.cameras[it->second];
  }

  fs::path FilePath(const formats::CameraFile& file) const {
    const fs::path path = dir_ / file.path;
    fs::create_directories(path.parent_path());
    return path;
  }

  // Homes a stage that is not homed, then moves it, retrying what a retry
  // can cure (a timeout: wait again; a stall: home again).
  void Move(drivers::RotaryStage& stage, double angle_rad) {
    for (int attempt = 0;; ++attempt) {
      try {
        if (!stage.IsHomed()) stage.Home();
        stage.MoveTo(angle_rad);
        stage.WaitUntilStopped(options_.move_timeout);
        return;
      } catch (const drivers::TimeoutError& e) {
        Retry(attempt, e);
      } catch (const drivers::StallError& e) {
        Retry(attempt, e);
      }
    }
  }

  void Tilt(double tilt_rad) {
    for (int attempt = 0;; ++attempt) {
      try {
        rig_.laser->SetTilt(tilt_rad, options_.move_timeout);
        return;
      } catch (const drivers::TimeoutError& e) {
        Retry(attempt, e);
      } catch (const drivers::StallError& e) {
        Retry(attempt, e);
      }
    }
  }

  void Retry(int attempt, const drivers::DeviceError& e) {
    if (attempt >= options_.retries) {
      throw drivers::DeviceError(std::string(e.what()) + "; gave up after " + std::to_string(attempt + 1) + " tries");
    }
    spdlog::warn("{}; trying again", e.what());
    ++report_.retries;
  }

  // One frame of every camera the step names, in its files' order. Laser
  // frames are read mono: processing needs the stripe's intensity, not its
  // hue (a camera that still gives colour is averaged to grey where the
  // frames are used).
  // Every camera at its rig description's exposure unless the step sets
  // another (the mirror sphere's): set on each grab, so a step that stopped
  // midway never leaves its exposure to the next.
  std::vector<core::Image> GrabAll(const formats::PlannedStep& step, const std::vector<formats::CameraFile>& files,
                                   drivers::PixelFormat format, std::optional<double> exposure_us = std::nullopt) {
    std::vector<drivers::Camera*> cameras;
    for (const formats::CameraFile& f : files) cameras.push_back(&CameraFor(step, f));
    for (std::size_t i = 0; i < cameras.size(); ++i) {
      drivers::Camera* c = cameras[i];
      if (c->settings().pixel_format != format) c->SetPixelFormat(format);
      const double wanted = exposure_us ? *exposure_us : DescriptionExposure(files[i].camera);
      if (c->settings().exposure_us != wanted) c->SetExposure(wanted);
    }
    for (drivers::Camera* c : cameras) c->StartAcquisition();
    for (drivers::Camera* c : cameras) c->Trigger();
    std::vector<core::Image> images;
    for (drivers::Camera* c : cameras) {
      for (int attempt = 0;; ++attempt) {
        try {
          drivers::Frame frame = c->Grab(options_.frame_timeout);
          CountSequence(*c, frame.sequence);
          if (options_.frame_arrived) options_.frame_arrived(c->info().id, frame);
          images.push_back(std::move(frame.image));
          break;
        } catch (const drivers::TimeoutError& e) {
          Retry(attempt, e);
          c->Trigger();
        }
      }
    }
    report_.frames += images.size();
    return images;
  }

  void CountSequence(const drivers::Camera& camera, std::uint64_t sequence) {
    auto [it, first] = next_sequence_.try_emplace(camera.info().id, sequence);
    if (!first && sequence > it->second) report_.dropped_frames += sequence - it->second;
    it->second = sequence + 1;
  }

  void AllOff() {
    for (int i = 0; i < rig_.lamps->lamp_count(); ++i) {
      if (rig_.lamps->IsOn(i)) rig_.lamps->SetLamp(i, false);
    }
    if (rig_.laser->IsEnabled()) rig_.laser->SetEnabled(false);
  }

  void MountLaser(int mount) {
    if (rig_.laser->mount() == mount) return;
    operator_.MountLaser(mount);
    rig_.laser->SetMount(mount);
  }

  void RunStep(const formats::PlannedStep& step, const formats::CaptureStep& typed) {
    AllOff();
    if (!std::holds_alternative<formats::LaserCalibrationStep>(typed)) RemoveCalibrationPlate();
    if (!std::holds_alternative<formats::BoardImageStep>(typed)) RemoveBoard();
    if (!std::holds_alternative<formats::WhiteReferenceStep>(typed)) RemoveWhiteReference();
    if (!std::holds_alternative<formats::MirrorSphereStep>(typed)) RemoveMirrorSphere();
    std::visit([&](const auto& s) { Run(step, s); }, typed);
  }

  void Run(const formats::PlannedStep& step, const formats::LaserCalibrationStep& calibration) {
    // Sec. 3.2: the stripe at tilt 0 on a flat plate at a known height. The
    // plate is imaged at the turntable's zero, so the step records the same
    // images whatever the previous step (or session) left the turntable at.
    Move(*rig_.turntable, 0.0);
    Move(*rig_.light_arc, calibration.arc_rad);
    MountLaser(calibration.mount);
    // The plate stays on across consecutive steps at its height: the plans
    // order them so, and the operator lays each plate once.
    if (plate_height_mm_ != calibration.height_mm) {
      RemoveCalibrationPlate();
      operator_.PlaceCalibrationPlate(calibration.height_mm);
      plate_height_mm_ = calibration.height_mm;
    }
    rig_.laser->SetEnabled(true);
    Tilt(calibration.tilt_rad);
    std::vector<core::Image> images = GrabAll(step, calibration.files, drivers::PixelFormat::kMono);
    rig_.laser->SetEnabled(false);
    WriteImages(MonoImages(std::move(images)), calibration.files);
  }

  void Run(const formats::PlannedStep& step, const formats::BoardImageStep& board) {
    Move(*rig_.turntable, board.turntable_rad);
    if (board_holder_ != board.holder) {
      operator_.PlaceCalibrationBoard(board.holder, board.holder_tilt_rad);
      board_holder_ = board.holder;
    }
    WriteImages(MonoImages(GrabAll(step, board.files, drivers::PixelFormat::kMono)), board.files);
  }

  // The plate comes off before any other step, and at the end.
  void RemoveCalibrationPlate() {
    if (!plate_height_mm_) return;
    operator_.RemoveCalibrationPlate();
    plate_height_mm_.reset();
  }

  // The board comes off the turntable before any other step, and at the end.
  void RemoveBoard() {
    if (!board_holder_) return;
    operator_.RemoveCalibrationBoard();
    board_holder_.reset();
  }

  // The white reference stays on the turntable across its lamps' steps.
  void Run(const formats::PlannedStep& step, const formats::WhiteReferenceStep& white) {
    if (!white_reference_placed_) {
      operator_.PlaceWhiteReference(rig_description_.white_reference->height_mm);
      white_reference_placed_ = true;
    }
    Move(*rig_.turntable, 0.0);  // as for the laser plates: images independent of the previous step
    Move(*rig_.light_arc, white.arc_rad);
    rig_.lamps->SetLamp(white.lamp, true);
    WriteImages(GrabAll(step, white.files, drivers::PixelFormat::kNative), white.files);
  }

  void RemoveWhiteReference() {
    if (!white_reference_placed_) return;
    operator_.RemoveWhiteReference();
    white_reference_placed_ = false;
  }

  // The sphere stays in its cup across its steps; each is imaged at the
  // sphere's own exposure.
  void Run(const formats::PlannedStep& step, const formats::MirrorSphereStep& sphere) {
    if (!mirror_sphere_placed_) {
      operator_.PlaceMirrorSphere();
      mirror_sphere_placed_ = true;
    }
    Move(*rig_.turntable, sphere.turntable_rad);
    Move(*rig_.light_arc, sphere.arc_rad);
    rig_.lamps->SetLamp(sphere.lamp, true);
    WriteImages(GrabAll(step, sphere.files, drivers::PixelFormat::kNative, rig_description_.mirror_sphere->exposure_us),
                sphere.files);
  }

  void RemoveMirrorSphere() {
    if (!mirror_sphere_placed_) return;
    operator_.RemoveMirrorSphere();
    mirror_sphere_placed_ = false;
  }

  // A mono readout's frames, one channel each.
  static std::vector<core::Image> MonoImages(std::vector<core::Image> images) {
    for (core::Image& image : images) image = core::ChannelMean(std::move(image));
    return images;
  }

  // One encoder per camera at once: PNG encoding is single-threaded.
  void WriteImages(const std::vector<core::Image>& images, const std::vector<formats::CameraFile>& files) {
    std::vector<fs::path> paths;
    for (std::size_t i = 0; i < images.size(); ++i) paths.push_back(FilePath(files[i]));
    tbb::parallel_for(std::size_t{0}, images.size(),
                      [&](std::size_t i) { core::WriteImage(paths[i], images[i], core::PixelEncoding::kUInt16); });
  }

  void Run(const formats::PlannedStep& step, const formats::BtfImageStep& btf) {
    Move(*rig_.turntable, btf.turntable_rad);
    Move(*rig_.light_arc, btf.arc_rad);
    rig_.lamps->SetLamp(btf.lamp, true);
    WriteImages(GrabAll(step, btf.files, drivers::PixelFormat::kNative), btf.files);
  }

  void Run(const formats::PlannedStep& step, const formats::LaserSweepStep& sweep) {
    Move(*rig_.turntable, sweep.turntable_rad);
    Move(*rig_.light_arc, sweep.arc_rad);
    MountLaser(sweep.mount);
    Tilt(sweep.tilts_rad.at(0));
    // Frames go to disk, or into the analysis, as they arrive: a sweep
    // is never in memory.
    std::vector<std::unique_ptr<formats::FrameSequenceWriter>> writers;
    std::vector<std::unique_ptr<mdf::LaserSweepProcessor>> analyses;
    if (sweep.stores_analysis) analyses = SweepProcessors(sweep);
    // Frame f is encoded while frame f + 1 is grabbed: a camera's frame is
    // grabbed in part on one thread, and encoding fills the other. Declared
    // after the writers, so that an exception waits for it before they go.
    tbb::task_group encoding;
    rig_.laser->SetEnabled(true);
    for (std::size_t f = 0; f < sweep.tilts_rad.size(); ++f) {
      Tilt(sweep.tilts_rad[f]);
      std::vector<core::Image> images = GrabAll(step, sweep.files, drivers::PixelFormat::kMono);
      if (!analyses.empty()) {
        // The cameras' analyses are independent (line detection and the
        // space-time state are single-threaded each).
        tbb::parallel_for(std::size_t{0}, images.size(), [&](std::size_t i) {
          analyses[i]->AddFrame(static_cast<int>(f), core::ChannelMean(std::move(images[i])));
        });
        continue;
      }
      encoding.wait();  // the previous frame's: a writer takes its frames in order
      if (writers.empty()) {
        for (std::size_t i = 0; i < images.size(); ++i) {
          writers.push_back(std::make_unique<formats::FrameSequenceWriter>(
              FilePath(sweep.files[i]), images[i].width(), images[i].height(), 1, core::PixelEncoding::kUInt16));
        }
      }
      // One encoder per camera at once, as for the still images.
      encoding.run([&writers, frame = std::make_shared<std::vector<core::Image>>(std::move(images))] {
        tbb::parallel_for(std::size_t{0}, frame->size(),
                          [&](std::size_t i) { writers[i]->Append(core::ChannelMean(std::move((*frame)[i]))); });
      });
    }
    encoding.wait();
    rig_.laser->SetEnabled(false);
    for (auto& w : writers) w->Commit();
    for (std::size_t i = 0; i < analyses.size(); ++i) {
      formats::WriteSweepAnalysis(FilePath(sweep.files[i]), analyses[i]->Finish());
    }
  }

  // One streaming analysis per file of the sweep step, in its files' order.
  // The laser planes come from this session's calibration plates, which
  // the plan captures before any sweep.
  std::vector<std::unique_ptr<mdf::LaserSweepProcessor>> SweepProcessors(const formats::LaserSweepStep& sweep) {
    if (!sweep_geometry_) {
      // The plates' files were journaled (and, on a resume, checked) before any sweep.
      sweep_geometry_ = std::make_unique<mdf::SessionSweepGeometry>(
          dir_ / formats::kSessionManifestName, manifest_, [this](const std::string& path) { return dir_ / path; },
          rig_description_, *options_.calibration, options_.sweep_geometry);
    }
    const mdf::SweepPoses poses = sweep_geometry_->Poses(sweep);
    std::vector<std::unique_ptr<mdf::LaserSweepProcessor>> processors;
    for (const formats::CameraFile& f : sweep.files) {
      const int camera = sweep_geometry_->CameraIndex(f.camera);
      processors.push_back(std::make_unique<mdf::LaserSweepProcessor>(
          sweep_geometry_->rays(camera), sweep_geometry_->Geometry(sweep, poses, camera), options_.sweep_geometry.line,
          options_.space_time));
    }
    return processors;
  }

  void Journal(const formats::PlannedStep& step, const formats::CaptureStep& typed) {
    formats::JournalRecord record;
    record.seq = journal_.next_seq();
    record.step = step.id;
    record.time_utc = formats::UtcTimestamp(std::chrono::system_clock::now());
    const auto* sweep = std::get_if<formats::LaserSweepStep>(&typed);
    for (const formats::CameraFile& f : formats::Files(typed)) {
      record.files.push_back({f.path, fs::file_size(dir_ / f.path), std::nullopt});
      if (sweep && sweep->stores_analysis) {
        const std::string image = formats::SweepAnalysisImagePath(f.path);
        record.files.push_back({image, fs::file_size(dir_ / image), std::nullopt});
      }
    }
    journal_.Append(record);
  }

  fs::path dir_;
  formats::SessionManifest manifest_;
  formats::RigDescription rig_description_;  // the rig the session records
  std::vector<formats::CaptureStep> steps_;  // the plan's steps, typed
  drivers::Rig& rig_;
  drivers::RigOperator& operator_;
  CaptureRunnerOptions options_;
  formats::CaptureJournal journal_;
  std::map<std::string, std::size_t> camera_index_;
  std::map<std::string, std::uint64_t> next_sequence_;
  CaptureRunReport report_;
  std::optional<double> plate_height_mm_;  // the laser calibration plate's height while it is on the turntable
  std::optional<int> board_holder_;        // the calibration board's holder tilt while it is on the turntable
  bool white_reference_placed_ = false;
  bool mirror_sphere_placed_ = false;
  // Made at the first sweep that stores its analysis.
  std::unique_ptr<mdf::SessionSweepGeometry> sweep_geometry_;
};

}  // namespace

core::CheckResult CaptureRunnerOptions::Check() const {
  if (frame_timeout.count() <= 0) return "frame_timeout must be positive";
  if (move_timeout.count() <= 0) return "move_timeout must be positive";
  if (retries < 0 || retries > 100) return "retries must be 0..100";
  if (const auto problem = sweep_geometry.Check(); !problem.empty()) return problem;
  if (const auto problem = space_time.Check(); !problem.empty()) return problem;
  return {};
}

CaptureRunReport RunCaptureSession(const fs::path& dir, drivers::Rig& rig, drivers::RigOperator& rig_operator,
                                   const CaptureRunnerOptions& options, const CaptureStepDone& step_done) {
  core::ThrowIfInvalid(options.Check(), "capture options");
  if (options.operator_prompt) {
    PromptedOperator prompted(rig_operator, options.operator_prompt);
    return SessionRun(dir, rig, prompted, options).Run(step_done);
  }
  return SessionRun(dir, rig, rig_operator, options).Run(step_done);
}

}  // namespace mesocap::acquisition
