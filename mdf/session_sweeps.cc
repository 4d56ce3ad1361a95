#include "mdf/session_sweeps.h"

#include <spdlog/spdlog.h>
#include <algorithm>
#include <cmath>

#include "calibration/laser_plane_calibration.h"
#include "calibration/rig_frames.h"
#include "core/angles.h"
#include "core/error.h"
#include "core/image_io.h"
#include "formats/capture_session.h"

namespace mesocap::mdf {
namespace {

namespace fs = std::filesystem;

}  // namespace

core::CheckResult SweepGeometryOptions::Check() const {
  if (const auto problem = line.Check(); !problem.empty()) return problem;
  if (!(reference_margin_mm >= 0)) return "reference_margin_mm must be >= 0";
  if (!(reference_extent > 0.5)) return "reference_extent must exceed 0.5 (the sample's half size)";
  return {};
}

SessionSweepGeometry::SessionSweepGeometry(const fs::path& manifest_file, const formats::SessionManifest& manifest,
                                           SessionFiles files, formats::RigDescription rig,
                                           const formats::Calibration& calibration, SweepGeometryOptions options)
    : SessionSweepGeometry(std::move(rig), calibration, {}, nullptr, std::move(options)) {
  files_ = std::move(files);
  manifest_file_ = manifest_file;
  for (std::size_t s = 0; s < manifest.plan.size(); ++s) {
    const formats::PlannedStep& step = manifest.plan[s];
    if (step.kind != formats::StepKind::kLaserCalibration) continue;
    AddPlate(formats::ReadLaserCalibrationStep(step, s, rig_, manifest_file_));
  }
}

SessionSweepGeometry::SessionSweepGeometry(formats::RigDescription rig, const formats::Calibration& calibration,
                                           std::vector<formats::LaserCalibrationStep> plates, PlateFrame plate_frame,
                                           SweepGeometryOptions options)
    : manifest_file_(formats::kSessionManifestName),
      plate_frame_(std::move(plate_frame)),
      rig_(std::move(rig)),
      calibration_(calibration),
      options_(std::move(options)) {
  core::ThrowIfInvalid(options_.Check(), "sweep geometry");
  // Every camera of the session's rig must be calibrated, at the size the
  // rig records (a calibration of another rig fails here, not mid-way).
  for (const auto& camera : rig_.cameras) {
    const formats::CameraCalibration* match = nullptr;
    for (const auto& c : calibration_.cameras) {
      if (c.id == camera.id) match = &c;
    }
    if (!match) {
      throw core::Error("calibration has no camera " + core::Quoted(camera.id) + " of the session's rig " +
                        core::Quoted(rig_.name));
    }
    if (match->width != camera.width || match->height != camera.height) {
      throw core::Error("calibration camera \"" + match->id + "\" is " + std::to_string(match->width) + "x" +
                        std::to_string(match->height) + " but the session's rig records " +
                        std::to_string(camera.width) + "x" + std::to_string(camera.height) +
                        " (a calibration of another rig?)");
    }
    rays_.emplace_back(*match);
  }
  for (const auto& loc : rig_.laser.locations)
    calibration::MountInWorld(calibration_, loc.mount, 0.0, 0.0);  // throws if missing
  for (auto& plate : plates) AddPlate(std::move(plate));
}

void SessionSweepGeometry::AddPlate(formats::LaserCalibrationStep plate) {
  Plates& plates = plates_[plate.location];
  if (!plates.heights.empty() && std::abs(plates.tilt_rad - plate.tilt_rad) > 1e-9) {
    throw core::FormatError(manifest_file_, "plan",
                            "the same tilt on both plates of laser location " + std::to_string(plate.location));
  }
  plates.tilt_rad = plate.tilt_rad;
  plates.heights.push_back(std::move(plate));
}

int SessionSweepGeometry::CameraIndex(const std::string& id) const {
  for (std::size_t c = 0; c < rig_.cameras.size(); ++c) {
    if (rig_.cameras[c].id == id) return static_cast<int>(c);
  }
  throw core::Error("the session's rig " + core::Quoted(rig_.name) + " has no camera " + core::Quoted(id));
}

core::Image SessionSweepGeometry::ReadPlateFrame(int location, int plate, int camera) const {
  const std::string& id = rig_.cameras[camera].id;
  const auto& files = plates_.at(location).heights[plate].files;
  const auto f =
      std::find_if(files.begin(), files.end(), [&](const formats::CameraFile& file) { return file.camera == id; });
  if (f == files.end()) {
    throw core::FormatError(manifest_file_, "plan",
                            "a laser calibration file of camera " + id + " for location " + std::to_string(location));
  }
  return core::ReadImage(files_(f->path),
                         formats::SessionFrameReadOptions(rays_[camera].width(), rays_[camera].height(), 1));
}

const core::Plane& SessionSweepGeometry::CalibratedPlane(int location, int camera) {
  const auto known = planes_.find({location, camera});
  if (known != planes_.end()) return known->second.plane;
  const auto it = plates_.find(location);
  if (it == plates_.end() || it->second.heights.size() != 2) {
    throw core::FormatError(
        manifest_file_, "plan",
        "two laser_calibration steps (two plate heights) for laser location " + std::to_string(location));
  }
  const auto& loc = rig_.laser.locations.at(location);
  const calibration::LaserMountPose pose =
      calibration::MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, it->second.tilt_rad);
  core::Image frames[2];
  for (int h = 0; h < 2; ++h) {
    frames[h] = plate_frame_ ? plate_frame_(location, h, camera) : ReadPlateFrame(location, h, camera);
  }
  const auto& heights = it->second.heights;
  calibration::LaserPlaneFit fit = calibration::CalibrateLaserPlane(
      frames[0], heights[0].height_mm, frames[1], heights[1].height_mm, rays_[camera],
      pose.normal.head<2>().normalized(), options_.reference_extent * rig_.sample_size_mm, options_.line,
      "laser location " + std::to_string(location) + ", camera " + rig_.cameras[camera].id);
  spdlog::debug(
      "laser location {}, camera {}: plane at {:.3f} deg to the reference plane, position sigma {:.4f} mm, "
      "normal sigma {:.4f} deg, height sigma {:.4f} mm",
      location, rig_.cameras[camera].id, core::DegreesFromRadians(calibration::AngleToReferencePlane(fit.plane)),
      fit.position_sigma_mm, core::DegreesFromRadians(fit.normal_sigma_rad), fit.height_sigma_mm);
  return planes_.emplace(std::make_pair(location, camera), std::move(fit)).first->second.plane;
}

SweepPoses SessionSweepGeometry::Poses(const formats::LaserSweepStep& step) const {
  SweepPoses poses;
  poses.world_from_sample = calibration::WorldFromSample(calibration_.turntable, step.turntable_rad);
  poses.sample_from_world = poses.world_from_sample.Inverse();
  poses.mount = calibration::MountInWorld(calibration_, step.mount, step.arc_rad, 0.0);
  return poses;
}

SweepGeometry SessionSweepGeometry::Geometry(const formats::LaserSweepStep& step, const SweepPoses& poses, int camera) {
  SweepGeometry geometry;
  geometry.calibrated_plane = CalibratedPlane(step.location, camera);
  const double calibration_tilt = plates_.at(step.location).tilt_rad;
  const long long key = std::llround(core::DegreesFromRadians(step.turntable_rad) * 1e6);
  auto region = regions_.find({key, camera});
  if (region == regions_.end()) {
    calibration::PixelMask mask =
        ReferenceRegion(rays_[camera], poses.world_from_sample, rig_.sample_size_mm, options_.reference_margin_mm,
                        options_.reference_extent * rig_.sample_size_mm);
    region = regions_.emplace(std::make_pair(key, camera), std::move(mask)).first;
  }
  geometry.reference_region = region->second;
  geometry.tilt_axis = poses.mount.tilt_axis;
  for (double t : step.tilts_rad) geometry.delta_tilt_rad.push_back(t - calibration_tilt);
  return geometry;
}

int SessionSweepGeometry::View(const core::SamplingSet& views, const SweepPoses& poses, int camera) const {
  return views.Nearest(poses.sample_from_world.Apply(rays_[camera].centre()).normalized());
}

void SessionSweepGeometry::AddToMdf(MdfAssembler& assembler, int view, const formats::LaserSweepStep& step,
                                    const SweepPoses& poses, int camera, const formats::SweepAnalysis& analysis) {
  const calibration::CameraRays& rays = rays_[camera];
  const double weight =
      ScanWeight(poses.mount.source, rays.centre(), CalibratedPlane(step.location, camera), 0.5 * rig_.sample_size_mm);
  assembler.AddSweep(view, analysis, rays, poses.world_from_sample, weight);
}

}  // namespace mesocap::mdf
