#include "mdf/session_sweeps.h"

#include <cmath>
#include <numbers>

#include "calibration/laser_plane_calibration.h"
#include "calibration/rig_frames.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"

namespace mesocap::mdf {
namespace {

namespace fs = std::filesystem;
constexpr double kRadPerDeg = std::numbers::pi / 180.0;

// The per-camera files of a step: camera id -> path inside the session.
std::map<std::string, std::string> StepFiles(const core::JsonFieldReader& step) {
  std::map<std::string, std::string> files;
  for (const auto& f : step.Objects("files", formats::kMaxRigParts)) {
    const std::string path = f.String("path");
    if (!formats::IsSessionPath(path)) f.Fail("path", "a relative path inside the session folder");
    files[f.String("camera")] = path;
  }
  return files;
}

std::string Where(std::size_t index) { return "plan[" + std::to_string(index) + "]"; }

}  // namespace

core::CheckResult SweepGeometryOptions::Check() const {
  if (const auto problem = line.Check(); !problem.empty()) return problem;
  if (!(reference_margin_mm >= 0)) return "reference_margin_mm must be >= 0";
  if (!(reference_extent > 0.5)) return "reference_extent must exceed 0.5 (the sample's half size)";
  return {};
}

SweepStep ParseSweepStep(const formats::PlannedStep& step, std::size_t index, const formats::RigDescription& rig,
                         const fs::path& manifest_file) {
  const core::JsonFieldReader fields(step.params, manifest_file, Where(index));
  SweepStep out;
  out.location = static_cast<int>(fields.Integer("location", 0, static_cast<std::int64_t>(rig.laser.locations.size()) - 1));
  out.mount = static_cast<int>(fields.Integer("mount", 0, formats::kMaxRigParts));
  out.turntable_rad = fields.Number("turntable_deg", -360, 360) * kRadPerDeg;
  out.arc_rad = fields.Number("arc_deg", -360, 360) * kRadPerDeg;
  for (double t : fields.Numbers("tilt_deg", fields.Raw("tilt_deg").size())) out.tilts_rad.push_back(t * kRadPerDeg);
  if (out.tilts_rad.empty()) fields.Fail("tilt_deg", "at least one frame's tilt");
  out.files = StepFiles(fields);
  out.stores_analysis = fields.Has("stored_as") && fields.Choice("stored_as", {"frames", "analysis"}) == "analysis";
  return out;
}

SessionSweepGeometry::SessionSweepGeometry(fs::path session, const formats::SessionManifest& manifest,
                                           formats::RigDescription rig, const formats::Calibration& calibration,
                                           SweepGeometryOptions options)
    : session_(std::move(session)),
      manifest_file_(session_ / formats::kSessionManifestName),
      rig_(std::move(rig)),
      calibration_(calibration),
      options_(std::move(options)) {
  if (const auto problem = options_.Check(); !problem.empty()) throw core::Error("sweep geometry: " + problem);
  // Every camera of the session's rig must be calibrated, at the size the
  // rig records (a calibration of another rig fails here, not mid-way).
  for (const auto& camera : rig_.cameras) {
    const formats::CameraCalibration* match = nullptr;
    for (const auto& c : calibration_.cameras) {
      if (c.id == camera.id) match = &c;
    }
    if (!match) {
      throw core::Error("calibration has no camera \"" + camera.id + "\" of the session's rig \"" + rig_.name + "\"");
    }
    if (match->width != camera.width || match->height != camera.height) {
      throw core::Error("calibration camera \"" + match->id + "\" is " + std::to_string(match->width) + "x" +
                  std::to_string(match->height) + " but the session's rig records " + std::to_string(camera.width) +
                  "x" + std::to_string(camera.height) + " (a calibration of another rig?)");
    }
    rays_.emplace_back(*match);
  }
  for (const auto& loc : rig_.laser.locations) calibration::MountInWorld(calibration_, loc.mount, 0.0, 0.0);  // throws if missing
  for (std::size_t s = 0; s < manifest.plan.size(); ++s) {
    const formats::PlannedStep& step = manifest.plan[s];
    if (step.kind != formats::StepKind::kLaserCalibration) continue;
    const core::JsonFieldReader fields(step.params, manifest_file_, Where(s));
    const int li = static_cast<int>(fields.Integer("location", 0, static_cast<std::int64_t>(rig_.laser.locations.size()) - 1));
    const double tilt = fields.NumberOr("tilt_deg", 0.0, -90, 90) * kRadPerDeg;
    Plates& plates = plates_[li];
    if (!plates.heights.empty() && std::abs(plates.tilt_rad - tilt) > 1e-9) {
      throw core::FormatError(manifest_file_, "plan", "the same tilt_deg on both plates of laser location " + std::to_string(li));
    }
    plates.tilt_rad = tilt;
    plates.heights.emplace_back(fields.Number("height_mm"), StepFiles(fields));
  }
}

int SessionSweepGeometry::CameraIndex(const std::string& id) const {
  for (std::size_t c = 0; c < rig_.cameras.size(); ++c) {
    if (rig_.cameras[c].id == id) return static_cast<int>(c);
  }
  throw core::Error("the session's rig \"" + rig_.name + "\" has no camera \"" + id + "\"");
}

const core::Plane& SessionSweepGeometry::CalibratedPlane(int location, int camera) {
  const auto known = planes_.find({location, camera});
  if (known != planes_.end()) return known->second;
  const auto it = plates_.find(location);
  if (it == plates_.end() || it->second.heights.size() != 2) {
    throw core::FormatError(manifest_file_, "plan",
                      "two laser_calibration steps (two plate heights) for laser location " + std::to_string(location));
  }
  const auto& loc = rig_.laser.locations.at(location);
  const calibration::LaserMountPose pose = calibration::MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, it->second.tilt_rad);
  const std::string& id = rig_.cameras[camera].id;
  core::Image frames[2];
  for (int h = 0; h < 2; ++h) {
    const auto& files = it->second.heights[h].second;
    const auto f = files.find(id);
    if (f == files.end()) {
      throw core::FormatError(manifest_file_, "plan",
                        "a laser calibration file of camera " + id + " for location " + std::to_string(location));
    }
    core::ImageReadOptions read;
    read.expected_width = rays_[camera].width();
    read.expected_height = rays_[camera].height();
    read.expected_channels = 1;
    frames[h] = core::ReadImage(session_ / f->second, read);
  }
  const core::Plane plane = calibration::CalibrateLaserPlane(frames[0], it->second.heights[0].first, frames[1],
                                          it->second.heights[1].first, rays_[camera], pose.normal.head<2>().normalized(),
                                          options_.reference_extent * rig_.sample_size_mm, options_.line,
                                          "laser location " + std::to_string(location) + ", camera " + id);
  return planes_.emplace(std::make_pair(location, camera), plane).first->second;
}

SweepGeometry SessionSweepGeometry::Geometry(const SweepStep& step, int camera) {
  SweepGeometry geometry;
  geometry.calibrated_plane = CalibratedPlane(step.location, camera);
  const double calibration_tilt = plates_.at(step.location).tilt_rad;
  const long long key = std::llround(step.turntable_rad / kRadPerDeg * 1e6);
  auto region = regions_.find({key, camera});
  if (region == regions_.end()) {
    region = regions_
                 .emplace(std::make_pair(key, camera),
                          ReferenceRegion(rays_[camera], calibration::WorldFromSample(calibration_.turntable, step.turntable_rad),
                                          rig_.sample_size_mm, options_.reference_margin_mm,
                                          options_.reference_extent * rig_.sample_size_mm))
                 .first;
  }
  geometry.reference_region = region->second;
  geometry.tilt_axis = calibration::MountInWorld(calibration_, step.mount, step.arc_rad, 0.0).tilt_axis;
  for (double t : step.tilts_rad) geometry.delta_tilt_rad.push_back(t - calibration_tilt);
  return geometry;
}

}  // namespace mesocap::mdf
