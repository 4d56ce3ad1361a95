#include "processing/mdf_session.h"

#include <map>
#include <numbers>
#include <string>

#include "core/capture_session.h"
#include "core/error.h"
#include "core/frame_sequence.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "drivers/rig_description.h"
#include "processing/camera_rays.h"
#include "processing/laser_sweep.h"
#include "processing/mdf_assembler.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;
constexpr double kRadPerDeg = std::numbers::pi / 180.0;

// The per-camera files of a step: camera id -> path inside the session.
std::map<std::string, std::string> StepFiles(const JsonFieldReader& step) {
  std::map<std::string, std::string> files;
  for (const auto& f : step.Objects("files", kMaxRigParts)) {
    const std::string path = f.String("path");
    if (!IsSessionPath(path)) f.Fail("path", "a relative path inside the session folder");
    files[f.String("camera")] = path;
  }
  return files;
}

const std::string& FileFor(const std::map<std::string, std::string>& files, const JsonFieldReader& step,
                           const std::string& camera) {
  const auto it = files.find(camera);
  if (it == files.end()) step.Fail("files", "an entry for camera " + camera);
  return it->second;
}

}  // namespace

CheckResult MdfProcessingOptions::Check() const {
  if (texture_size < 1 || texture_size > 4096) return "texture_size must be in 1..4096";
  for (const auto& problem : {line.Check(), space_time.Check(), triangulation.Check(), merge.Check()}) {
    if (!problem.empty()) return problem;
  }
  if (!(reference_margin_mm >= 0)) return "reference_margin_mm must be >= 0";
  if (!(reference_extent > 0.5)) return "reference_extent must exceed 0.5 (the sample's half size)";
  return {};
}

MdfProcessingResult ProcessMdfSession(const fs::path& session, const Calibration& calibration,
                                      const MdfProcessingOptions& options, Progress::Style progress_style) {
  if (const auto problem = options.Check(); !problem.empty()) throw Error("process mdf: " + problem);
  const SessionManifest manifest = ReadSessionManifest(session);
  const fs::path manifest_file = session / kSessionManifestName;
  const drivers::RigDescription rig = drivers::ParseRigDescription(manifest.rig, manifest_file);
  // Every camera of the session's rig must be calibrated, at the size the
  // rig records (a calibration of another rig fails here, not mid-way).
  std::vector<int> calibration_index(rig.cameras.size(), -1);
  for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
    for (std::size_t k = 0; k < calibration.cameras.size(); ++k) {
      if (calibration.cameras[k].id == rig.cameras[c].id) calibration_index[c] = static_cast<int>(k);
    }
    if (calibration_index[c] < 0) {
      throw Error("calibration has no camera \"" + rig.cameras[c].id + "\" of the session's rig \"" + rig.name + "\"");
    }
    const auto& cal = calibration.cameras[calibration_index[c]];
    if (cal.width != rig.cameras[c].width || cal.height != rig.cameras[c].height) {
      throw Error("calibration camera \"" + cal.id + "\" is " + std::to_string(cal.width) + "x" +
                  std::to_string(cal.height) + " but the session's rig records " +
                  std::to_string(rig.cameras[c].width) + "x" + std::to_string(rig.cameras[c].height) +
                  " (a calibration of another rig?)");
    }
  }
  for (const auto& loc : rig.laser.locations) MountInWorld(calibration, loc.mount, 0.0, 0.0);  // throws if missing

  std::vector<bool> use_location(rig.laser.locations.size(), options.locations.empty());
  for (int li : options.locations) {
    if (li < 0 || li >= static_cast<int>(use_location.size())) {
      throw Error("process mdf: laser location " + std::to_string(li) + " is not in the rig (it has " +
                  std::to_string(use_location.size()) + ")");
    }
    use_location[li] = true;
  }

  std::vector<CameraRays> rays;
  for (int k : calibration_index) rays.emplace_back(calibration.cameras[k]);
  const double sample_size = rig.sample_size_mm;
  const double outer_mm = options.reference_extent * sample_size;
  const SamplingSet views = drivers::ViewDirections(rig);
  TextureGrid grid{options.texture_size, options.texture_size, sample_size};
  MdfAssembler assembler(grid, views, options.triangulation, options.merge);

  // Laser-plane calibration frames: per location and height, per camera.
  struct PlateStep {
    double height_mm = 0;
    double tilt_rad = 0;
    std::map<std::string, std::string> files;
  };
  std::map<int, std::vector<PlateStep>> plates;
  std::vector<std::size_t> sweep_steps;
  for (std::size_t s = 0; s < manifest.plan.size(); ++s) {
    const PlannedStep& step = manifest.plan[s];
    const JsonFieldReader fields(step.params, manifest_file, "plan[" + std::to_string(s) + "]");
    if (step.kind == StepKind::kLaserCalibration) {
      const int li = static_cast<int>(fields.Integer("location", 0, rig.laser.locations.size() - 1));
      plates[li].push_back({fields.Number("height_mm"), fields.NumberOr("tilt_deg", 0.0, -90, 90) * kRadPerDeg,
                            StepFiles(fields)});
    } else if (step.kind == StepKind::kLaserSweep) {
      const int li = static_cast<int>(fields.Integer("location", 0, rig.laser.locations.size() - 1));
      if (use_location[li]) sweep_steps.push_back(s);
    }
  }
  std::map<std::pair<int, int>, Plane> calibrated;  // (location, camera)
  std::map<int, double> calibration_tilt_rad;       // per location
  for (std::size_t li = 0; li < rig.laser.locations.size(); ++li) {
    if (!use_location[li]) continue;
    const auto it = plates.find(static_cast<int>(li));
    if (it == plates.end() || it->second.size() != 2) {
      throw FormatError(manifest_file, "plan",
                        "two laser_calibration steps (two plate heights) for laser location " + std::to_string(li));
    }
    if (std::abs(it->second[0].tilt_rad - it->second[1].tilt_rad) > 1e-9) {
      throw FormatError(manifest_file, "plan", "the same tilt_deg on both plates of laser location " + std::to_string(li));
    }
    calibration_tilt_rad[static_cast<int>(li)] = it->second[0].tilt_rad;
    const auto& loc = rig.laser.locations[li];
    const LaserMountPose pose = MountInWorld(calibration, loc.mount, loc.arc_angle_rad, it->second[0].tilt_rad);
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      const std::string& id = rig.cameras[c].id;
      Image frames[2];
      for (int h = 0; h < 2; ++h) {
        const auto f = it->second[h].files.find(id);
        if (f == it->second[h].files.end()) {
          throw FormatError(manifest_file, "plan", "a laser calibration file of camera " + id + " for location " +
                                                       std::to_string(li));
        }
        ImageReadOptions read;
        read.expected_width = rays[c].width();
        read.expected_height = rays[c].height();
        read.expected_channels = 1;
        frames[h] = ReadImage(session / f->second, read);
      }
      calibrated[{static_cast<int>(li), static_cast<int>(c)}] = CalibrateLaserPlane(
          frames[0], it->second[0].height_mm, frames[1], it->second[1].height_mm, rays[c],
          pose.normal.head<2>().normalized(), outer_mm, options.line,
          "laser location " + std::to_string(li) + ", camera " + id);
    }
  }

  MdfProcessingResult result;
  result.sample_size_mm = sample_size;
  Progress progress("process mdf", sweep_steps.size() * rig.cameras.size(), progress_style);
  std::map<std::pair<long long, int>, PixelMask> regions;  // (turntable angle in micro-degrees, camera)
  for (std::size_t s : sweep_steps) {
    const PlannedStep& step = manifest.plan[s];
    const JsonFieldReader fields(step.params, manifest_file, "plan[" + std::to_string(s) + "]");
    const int li = static_cast<int>(fields.Integer("location", 0, rig.laser.locations.size() - 1));
    const double turntable_rad = fields.Number("turntable_deg", -360, 360) * kRadPerDeg;
    const double arc_rad = fields.Number("arc_deg", -360, 360) * kRadPerDeg;
    const int mount = static_cast<int>(fields.Integer("mount", 0, kMaxRigParts));
    const std::vector<double> tilts_deg = fields.Numbers("tilt_deg", fields.Raw("tilt_deg").size());
    if (tilts_deg.empty()) fields.Fail("tilt_deg", "at least one frame's tilt");
    const auto files = StepFiles(fields);
    const LaserMountPose pose = MountInWorld(calibration, mount, arc_rad, 0.0);
    const RigidTransform world_from_sample = WorldFromSample(calibration.turntable, turntable_rad);
    const RigidTransform sample_from_world = world_from_sample.Inverse();
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      const std::string& id = rig.cameras[c].id;
      const fs::path file = session / FileFor(files, fields, id);
      FrameSequenceReader reader(file);
      const FrameSequenceHeader& header = reader.header();
      if (header.width != rays[c].width() || header.height != rays[c].height()) {
        throw FormatError(file, "frame size",
                          std::to_string(rays[c].width()) + "x" + std::to_string(rays[c].height()) +
                              " (camera " + id + "'s calibration), found " + std::to_string(header.width) + "x" +
                              std::to_string(header.height));
      }
      if (header.channels != 1) throw FormatError(file, "channels", "1 (grey laser frames)");
      if (header.frame_count != static_cast<int>(tilts_deg.size())) {
        throw FormatError(file, "frame count",
                          std::to_string(tilts_deg.size()) + " (the plan's tilt_deg), found " +
                              std::to_string(header.frame_count));
      }
      const long long key = std::llround(turntable_rad / kRadPerDeg * 1e6);
      auto region = regions.find({key, static_cast<int>(c)});
      if (region == regions.end()) {
        region = regions
                     .emplace(std::make_pair(key, static_cast<int>(c)),
                              ReferenceRegion(rays[c], world_from_sample, sample_size,
                                              options.reference_margin_mm, outer_mm))
                     .first;
      }
      SweepGeometry geometry;
      geometry.reference_region = region->second;
      geometry.calibrated_plane = calibrated.at({li, static_cast<int>(c)});
      geometry.tilt_axis = pose.tilt_axis;
      for (double t : tilts_deg) geometry.delta_tilt_rad.push_back(t * kRadPerDeg - calibration_tilt_rad.at(li));
      LaserSweepProcessor processor(rays[c], geometry, options.line, options.space_time);
      Image frame;
      while (reader.Next(&frame)) processor.AddFrame(reader.next_index() - 1, frame);
      const SweepAnalysis analysis = processor.Finish();
      const Eigen::Vector3d to_camera = sample_from_world.Apply(rays[c].centre()).normalized();
      const double weight = ScanWeight(pose.source, rays[c].centre(), geometry.calibrated_plane, 0.5 * sample_size);
      assembler.AddSweep(views.Nearest(to_camera), analysis, rays[c], world_from_sample, weight);
      ++result.sweeps;
      progress.Advance();
    }
  }
  progress.Finish();
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

}  // namespace mesocap
