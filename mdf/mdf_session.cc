#include "mdf/mdf_session.h"

#include <algorithm>
#include <limits>
#include <string>

#include "calibration/camera_rays.h"
#include "calibration/nominal_geometry.h"
#include "core/error.h"
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/frame_sequence.h"
#include "formats/rig_description.h"
#include "formats/sweep_analysis.h"
#include "mdf/laser_sweep.h"
#include "mdf/mdf_assembler.h"
#include "mdf/session_sweeps.h"

namespace mesocap::mdf {
namespace {

namespace fs = std::filesystem;

// A sweep stored as frames: streamed through line detection and the
// space-time analysis.
formats::SweepAnalysis AnalyseFrames(const fs::path& file, const calibration::CameraRays& rays,
                                     const SweepGeometry& geometry, const MdfProcessingOptions& options) {
  formats::FrameSequenceReader reader(file);
  const formats::FrameSequenceHeader& header = reader.header();
  if (header.width != rays.width() || header.height != rays.height()) {
    throw core::FormatError(file, "frame size",
                            std::to_string(rays.width()) + "x" + std::to_string(rays.height()) +
                                " (the camera's calibration), found " + std::to_string(header.width) + "x" +
                                std::to_string(header.height));
  }
  if (header.channels != 1) throw core::FormatError(file, "channels", "1 (grey laser frames)");
  if (header.encoding != formats::kSessionFrameEncoding) {
    throw core::FormatError(file, "pixel type",
                            std::string("expected ") + core::ToString(formats::kSessionFrameEncoding) + ", got " +
                                core::ToString(header.encoding));
  }
  if (header.frame_count != static_cast<int>(geometry.delta_tilt_rad.size())) {
    throw core::FormatError(file, "frame count",
                            std::to_string(geometry.delta_tilt_rad.size()) + " (the plan's tilts), found " +
                                std::to_string(header.frame_count));
  }
  LaserSweepProcessor processor(rays, geometry, options.geometry.line, options.space_time);
  core::Image frame;
  while (reader.Next(&frame)) processor.AddFrame(reader.next_index() - 1, frame);
  return processor.Finish();
}

// A sweep the capture analysed as its frames arrived: peaks under this
// run's threshold become unknown (a stored analysis keeps every peak above
// half the capture's threshold).
formats::SweepAnalysis ReadStoredAnalysis(const fs::path& file, const calibration::CameraRays& rays,
                                          std::size_t frame_count, const SpaceTimeOptions& space_time) {
  formats::SweepAnalysis analysis = formats::ReadSweepAnalysis(file);
  if (analysis.width != rays.width() || analysis.height != rays.height()) {
    throw core::FormatError(file, "width, height",
                            std::to_string(rays.width()) + "x" + std::to_string(rays.height()) +
                                " (the camera's calibration), found " + std::to_string(analysis.width) + "x" +
                                std::to_string(analysis.height));
  }
  if (analysis.frame_count != static_cast<int>(frame_count)) {
    throw core::FormatError(
        file, "frame_count",
        std::to_string(frame_count) + " (the plan's tilts), found " + std::to_string(analysis.frame_count));
  }
  for (std::size_t p = 0; p < analysis.peak_time.size(); ++p) {
    if (!(analysis.peak_value[p] >= space_time.threshold))
      analysis.peak_time[p] = std::numeric_limits<float>::quiet_NaN();
    if (!(analysis.second_value[p] >= space_time.threshold)) {
      analysis.second_time[p] = std::numeric_limits<float>::quiet_NaN();
    }
  }
  return analysis;
}

}  // namespace

core::CheckResult MdfProcessingOptions::Check() const {
  if (texture_size < 1 || texture_size > 4096) return "texture_size must be in 1..4096";
  for (const auto& problem : {geometry.Check(), space_time.Check(), triangulation.Check(), merge.Check()}) {
    if (!problem.empty()) return problem;
  }
  return {};
}

MdfProcessingResult ProcessMdfSession(const formats::CapturedSession& session, const formats::Calibration& calibration,
                                      const MdfProcessingOptions& options, core::Progress::Style progress_style) {
  core::ThrowIfInvalid(options.Check(), "process mdf");
  const formats::SessionManifest& manifest = session.manifest();
  const fs::path manifest_file = session.manifest_file();
  const formats::RigDescription rig = formats::ParseRigDescription(manifest.rig, manifest_file);
  if (std::none_of(manifest.plan.begin(), manifest.plan.end(),
                   [](const formats::PlannedStep& step) { return step.kind == formats::StepKind::kLaserSweep; })) {
    throw core::Error("process mdf: " + manifest_file.string() +
                      ": the session plans no laser sweep (a BTF-only session, `simulate --plan btf`); an MDF needs a "
                      "capture session");
  }
  SessionSweepGeometry geometry(
      manifest_file, manifest, [&session](const std::string& path) { return session.IntactFile(path); }, rig,
      calibration, options.geometry);

  std::vector<bool> use_location(rig.laser.locations.size(), options.locations.empty());
  for (int li : options.locations) {
    if (li < 0 || li >= static_cast<int>(use_location.size())) {
      throw core::Error("process mdf: laser location " + std::to_string(li) + " is not in the rig (it has " +
                        std::to_string(use_location.size()) + ")");
    }
    use_location[li] = true;
  }
  std::vector<formats::LaserSweepStep> sweeps;
  for (std::size_t s = 0; s < manifest.plan.size(); ++s) {
    if (manifest.plan[s].kind != formats::StepKind::kLaserSweep || !session.IsDone(manifest.plan[s].id)) continue;
    formats::LaserSweepStep step = formats::ReadLaserSweepStep(manifest.plan[s], s, rig, manifest_file);
    if (use_location[step.location]) sweeps.push_back(std::move(step));
  }

  const double sample_size = rig.sample_size_mm;
  const core::SamplingSet views = calibration::ViewDirections(rig);
  calibration::TexelGrid grid{options.texture_size, options.texture_size, sample_size};
  TriangulationOptions triangulation = options.triangulation;
  triangulation.backing_depth_mm = rig.backing.depth_mm;  // "no hit" evidence, if the rig has a backing
  // The MDF, its confidence and one displacement image per view and sweep
  // being merged, in floats: a lower bound of what the assembler holds.
  const std::uint64_t texels = static_cast<std::uint64_t>(grid.width) * grid.height;
  core::CheckMemoryFor(4 * texels * views.size() * (2 + sweeps.size()),
                       "the MDF at " + std::to_string(grid.width) + "x" + std::to_string(grid.height) + " texels x " +
                           std::to_string(views.size()) + " views from " + std::to_string(sweeps.size()) +
                           " sweeps (--texture-size)");
  MdfAssembler assembler(grid, views, triangulation, options.merge);
  MdfProcessingResult result;
  result.sample_size_mm = sample_size;
  result.light_directions = calibration::LightDirections(rig);
  core::Progress progress("process mdf", sweeps.size() * rig.cameras.size(), progress_style);
  for (const formats::LaserSweepStep& step : sweeps) {
    const SweepPoses poses = geometry.Poses(step);
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      const std::string& id = rig.cameras[c].id;
      const calibration::CameraRays& rays = geometry.rays(static_cast<int>(c));
      const auto file_entry = std::find_if(step.files.begin(), step.files.end(),
                                           [&](const formats::CameraFile& f) { return f.camera == id; });
      if (file_entry == step.files.end()) {
        throw core::FormatError(
            manifest_file, "plan",
            "a laser sweep file of camera " + id + " for location " + std::to_string(step.location));
      }
      const fs::path file = session.IntactFile(file_entry->path);
      // A stored analysis needs no reference region: only the plane, for the weight.
      const int camera = static_cast<int>(c);
      if (step.stores_analysis && session.Journaled(formats::SweepAnalysisImagePath(file_entry->path))) {
        session.IntactFile(formats::SweepAnalysisImagePath(file_entry->path));
      }
      const formats::SweepAnalysis analysis =
          step.stores_analysis ? ReadStoredAnalysis(file, rays, step.tilts_rad.size(), options.space_time)
                               : AnalyseFrames(file, rays, geometry.Geometry(step, poses, camera), options);
      geometry.AddToMdf(assembler, geometry.View(views, poses, camera), step, poses, camera, analysis);
      ++result.sweeps;
      progress.Advance();
    }
  }
  progress.Finish();
  for (const auto& [key, fit] : geometry.calibrated_planes()) {
    ++result.laser_planes;
    result.worst_plane_height_sigma_mm = std::max(result.worst_plane_height_sigma_mm, fit.height_sigma_mm);
  }
  result.mdf = assembler.Finish(&result.confidence);
  for (int v = 0; v < result.mdf.view_count(); ++v) {
    const double cos_theta = views.direction(v).z();
    for (int j = 0; j < result.mdf.height; ++j) {
      for (int i = 0; i < result.mdf.width; ++i) {
        const float d = result.mdf.at(i, j, v);
        if (std::isfinite(d)) result.deepest_mm = std::max(result.deepest_mm, d * cos_theta);
      }
    }
  }
  return result;
}

}  // namespace mesocap::mdf
