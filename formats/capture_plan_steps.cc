#include "formats/capture_plan_steps.h"

#include <algorithm>
#include <cmath>

#include "core/angles.h"
#include "core/error.h"
#include "core/json_field_reader.h"
#include "formats/calibration.h"

namespace mesocap::formats {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Degrees rounded to 1e-9, so that the same radians always print the same.
double PlanDegrees(double rad) { return std::round(core::DegreesFromRadians(rad) * 1e9) / 1e9; }

json FilesJson(const std::vector<CameraFile>& files) {
  json list = json::array();
  for (const CameraFile& f : files) list.push_back({{"camera", f.camera}, {"path", f.path}});
  return list;
}

PlannedStep Planned(std::string id, StepKind kind, json params, const json& recording) {
  if (!recording.is_null()) params["recording"] = recording;
  return {std::move(id), kind, std::move(params)};
}

// One file per camera of the rig, in the rig's camera order.
std::vector<CameraFile> ReadFiles(const core::JsonFieldReader& step, const RigDescription& rig) {
  std::vector<CameraFile> files;
  const auto entries = step.Objects("files", kMaxRigParts);
  if (entries.size() != rig.cameras.size()) {
    step.Fail("files", "expected one file per camera of the rig (" + std::to_string(rig.cameras.size()) + "), got " +
                           std::to_string(entries.size()));
  }
  for (const auto& f : entries) {
    f.RejectUnknownMembers({"camera", "path"});
    const std::string path = f.String("path");
    if (!IsSessionPath(path)) f.Fail("path", "a relative path inside the session folder");
    files.push_back({f.String("camera"), path});
  }
  return files;
}

core::JsonFieldReader StepFields(const PlannedStep& step, StepKind kind, std::size_t index, const fs::path& file) {
  const std::string where = "plan[" + std::to_string(index) + "]";
  if (step.kind != kind) {
    throw core::FormatError(file, where + ".kind", std::string("expected \"") + ToString(kind) + "\"");
  }
  return core::JsonFieldReader(step.params, file, where);
}

int Location(const core::JsonFieldReader& fields, const RigDescription& rig) {
  return static_cast<int>(fields.Integer("location", 0, static_cast<std::int64_t>(rig.laser.locations.size()) - 1));
}

int Mount(const core::JsonFieldReader& fields, const RigDescription& rig) {
  return static_cast<int>(
      fields.Integer("mount", 0, static_cast<std::int64_t>(rig.laser.mount_elevations_rad.size()) - 1));
}

// An index into one of the rig's lists of `count` entries.
int Index(const core::JsonFieldReader& fields, std::string_view key, std::size_t count) {
  return static_cast<int>(fields.Integer(key, 0, static_cast<std::int64_t>(count) - 1));
}

double Radians(const core::JsonFieldReader& fields, std::string_view key) {
  return core::RadiansFromDegrees(fields.Number(key, -360, 360));
}

// The plate's height and a sweep's offsets, in mm: as far as the rig's
// lengths reach (docs/FORMATS.md "Rig description").
constexpr double kMaxPlanLengthMm = 1e5;
// The laser's tilt, degrees either side of its plane at tilt 0.
constexpr double kMaxTiltDeg = 90.0;

}  // namespace

PlannedStep ToPlannedStep(std::string id, const LaserCalibrationStep& step, const json& recording) {
  return Planned(std::move(id), StepKind::kLaserCalibration,
                 {{"location", step.location},
                  {"mount", step.mount},
                  {"arc_deg", PlanDegrees(step.arc_rad)},
                  {"height_mm", step.height_mm},
                  {"tilt_deg", PlanDegrees(step.tilt_rad)},
                  {"files", FilesJson(step.files)}},
                 recording);
}

PlannedStep ToPlannedStep(std::string id, const BtfImageStep& step, const json& recording) {
  return Planned(std::move(id), StepKind::kBtfImage,
                 {{"turntable_index", step.turntable_index},
                  {"turntable_deg", PlanDegrees(step.turntable_rad)},
                  {"arc_index", step.arc_index},
                  {"arc_deg", PlanDegrees(step.arc_rad)},
                  {"lamp", step.lamp},
                  {"lamp_elevation_deg", PlanDegrees(step.lamp_elevation_rad)},
                  {"files", FilesJson(step.files)}},
                 recording);
}

PlannedStep ToPlannedStep(std::string id, const LaserSweepStep& step, const json& recording) {
  json offsets = json::array();
  for (const double offset : step.offsets_mm) offsets.push_back(std::round(offset * 1e9) / 1e9);
  json tilts = json::array();
  for (const double tilt : step.tilts_rad) tilts.push_back(PlanDegrees(tilt));
  json params = {{"turntable_index", step.turntable_index},
                 {"turntable_deg", PlanDegrees(step.turntable_rad)},
                 {"location", step.location},
                 {"mount", step.mount},
                 {"arc_deg", PlanDegrees(step.arc_rad)},
                 {"offset_mm", std::move(offsets)},
                 {"tilt_deg", std::move(tilts)},
                 {"files", FilesJson(step.files)}};
  if (step.stores_analysis) params["stored_as"] = "analysis";
  return Planned(std::move(id), StepKind::kLaserSweep, std::move(params), recording);
}

PlannedStep ToPlannedStep(std::string id, const BoardImageStep& step, const json& recording) {
  return Planned(std::move(id), StepKind::kBoardImage,
                 {{"holder", step.holder},
                  {"holder_tilt_deg", PlanDegrees(step.holder_tilt_rad)},
                  {"turntable_index", step.turntable_index},
                  {"turntable_deg", PlanDegrees(step.turntable_rad)},
                  {"files", FilesJson(step.files)}},
                 recording);
}

PlannedStep ToPlannedStep(std::string id, const WhiteReferenceStep& step, const json& recording) {
  return Planned(std::move(id), StepKind::kWhiteReference,
                 {{"lamp", step.lamp}, {"arc_deg", PlanDegrees(step.arc_rad)}, {"files", FilesJson(step.files)}},
                 recording);
}

PlannedStep ToPlannedStep(std::string id, const MirrorSphereStep& step, const json& recording) {
  return Planned(std::move(id), StepKind::kMirrorSphere,
                 {{"turntable_index", step.turntable_index},
                  {"turntable_deg", PlanDegrees(step.turntable_rad)},
                  {"arc_index", step.arc_index},
                  {"arc_deg", PlanDegrees(step.arc_rad)},
                  {"lamp", step.lamp},
                  {"files", FilesJson(step.files)}},
                 recording);
}

LaserCalibrationStep ReadLaserCalibrationStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                              const fs::path& manifest_file) {
  const core::JsonFieldReader fields = StepFields(step, StepKind::kLaserCalibration, index, manifest_file);
  fields.RejectUnknownMembers({"location", "mount", "arc_deg", "height_mm", "tilt_deg", "files", "recording"});
  LaserCalibrationStep out;
  out.location = Location(fields, rig);
  out.mount = Mount(fields, rig);
  out.arc_rad = Radians(fields, "arc_deg");
  out.height_mm = fields.Number("height_mm", -kMaxPlanLengthMm, kMaxPlanLengthMm);
  out.tilt_rad = core::RadiansFromDegrees(fields.NumberOr("tilt_deg", 0.0, -kMaxTiltDeg, kMaxTiltDeg));
  out.files = ReadFiles(fields, rig);
  return out;
}

BtfImageStep ReadBtfImageStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                              const fs::path& manifest_file) {
  const core::JsonFieldReader fields = StepFields(step, StepKind::kBtfImage, index, manifest_file);
  fields.RejectUnknownMembers(
      {"turntable_index", "turntable_deg", "arc_index", "arc_deg", "lamp", "lamp_elevation_deg", "files", "recording"});
  BtfImageStep out;
  out.turntable_index = Index(fields, "turntable_index", rig.turntable.angles_rad.size());
  out.turntable_rad = Radians(fields, "turntable_deg");
  out.arc_index = Index(fields, "arc_index", rig.light_arc.angles_rad.size());
  out.arc_rad = Radians(fields, "arc_deg");
  out.lamp = Index(fields, "lamp", rig.lamps.elevations_rad.size());
  out.lamp_elevation_rad = Radians(fields, "lamp_elevation_deg");
  out.files = ReadFiles(fields, rig);
  return out;
}

LaserSweepStep ReadLaserSweepStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                  const fs::path& manifest_file) {
  const core::JsonFieldReader fields = StepFields(step, StepKind::kLaserSweep, index, manifest_file);
  fields.RejectUnknownMembers({"turntable_index", "turntable_deg", "location", "mount", "arc_deg", "offset_mm",
                               "tilt_deg", "stored_as", "files", "recording"});
  LaserSweepStep out;
  out.turntable_index = Index(fields, "turntable_index", rig.turntable.angles_rad.size());
  out.turntable_rad = Radians(fields, "turntable_deg");
  out.location = Location(fields, rig);
  out.mount = Mount(fields, rig);
  out.arc_rad = Radians(fields, "arc_deg");
  // One tilt and one offset per frame of the rig's sweep.
  const auto frames = static_cast<std::size_t>(rig.laser.frames_per_sweep);
  for (const std::string_view key : {"tilt_deg", "offset_mm"}) {
    const nlohmann::json& list = fields.Raw(key);
    if (!list.is_array() || list.size() != frames) {
      fields.Fail(
          key, "expected one number per frame of the rig's sweep (laser.frames_per_sweep = " + std::to_string(frames) +
                   "), got " + (list.is_array() ? std::to_string(list.size()) + " entries" : core::JsonExcerpt(list)));
    }
  }
  for (const double t : fields.Numbers("tilt_deg", frames, -kMaxTiltDeg, kMaxTiltDeg)) {
    out.tilts_rad.push_back(core::RadiansFromDegrees(t));
  }
  out.offsets_mm = fields.Numbers("offset_mm", frames, -kMaxPlanLengthMm, kMaxPlanLengthMm);
  out.stores_analysis = fields.Has("stored_as") && fields.Choice("stored_as", {"frames", "analysis"}) == "analysis";
  out.files = ReadFiles(fields, rig);
  return out;
}

BoardImageStep ReadBoardImageStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                  const fs::path& manifest_file) {
  const core::JsonFieldReader fields = StepFields(step, StepKind::kBoardImage, index, manifest_file);
  fields.RejectUnknownMembers({"holder", "holder_tilt_deg", "turntable_index", "turntable_deg", "files", "recording"});
  if (!rig.calibration_board) {
    throw core::FormatError(manifest_file, "plan[" + std::to_string(index) + "].kind",
                            "a board image needs the rig's calibration_board, which the session's rig lacks");
  }
  BoardImageStep out;
  out.holder = Index(fields, "holder", rig.calibration_board->holder_tilts_rad.size());
  out.holder_tilt_rad = Radians(fields, "holder_tilt_deg");
  out.turntable_index = Index(fields, "turntable_index", rig.calibration_board->turntable_angles_rad.size());
  out.turntable_rad = Radians(fields, "turntable_deg");
  out.files = ReadFiles(fields, rig);
  return out;
}

WhiteReferenceStep ReadWhiteReferenceStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                          const fs::path& manifest_file) {
  const core::JsonFieldReader fields = StepFields(step, StepKind::kWhiteReference, index, manifest_file);
  fields.RejectUnknownMembers({"lamp", "arc_deg", "files", "recording"});
  if (!rig.white_reference) {
    throw core::FormatError(manifest_file, "plan[" + std::to_string(index) + "].kind",
                            "a white reference image needs the rig's white_reference, which the session's rig lacks");
  }
  WhiteReferenceStep out;
  out.lamp = Index(fields, "lamp", rig.lamps.elevations_rad.size());
  out.arc_rad = Radians(fields, "arc_deg");
  out.files = ReadFiles(fields, rig);
  return out;
}

MirrorSphereStep ReadMirrorSphereStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                      const fs::path& manifest_file) {
  const core::JsonFieldReader fields = StepFields(step, StepKind::kMirrorSphere, index, manifest_file);
  fields.RejectUnknownMembers(
      {"turntable_index", "turntable_deg", "arc_index", "arc_deg", "lamp", "files", "recording"});
  if (!rig.mirror_sphere) {
    throw core::FormatError(manifest_file, "plan[" + std::to_string(index) + "].kind",
                            "a mirror sphere image needs the rig's mirror_sphere, which the session's rig lacks");
  }
  MirrorSphereStep out;
  out.turntable_index = Index(fields, "turntable_index", rig.mirror_sphere->turntable_angles_rad.size());
  out.turntable_rad = Radians(fields, "turntable_deg");
  out.arc_index = Index(fields, "arc_index", rig.mirror_sphere->arc_angles_rad.size());
  out.arc_rad = Radians(fields, "arc_deg");
  out.lamp = Index(fields, "lamp", rig.lamps.elevations_rad.size());
  out.files = ReadFiles(fields, rig);
  return out;
}

CaptureStep ReadCaptureStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                            const fs::path& manifest_file) {
  switch (step.kind) {
    case StepKind::kLaserCalibration:
      return ReadLaserCalibrationStep(step, index, rig, manifest_file);
    case StepKind::kBtfImage:
      return ReadBtfImageStep(step, index, rig, manifest_file);
    case StepKind::kLaserSweep:
      return ReadLaserSweepStep(step, index, rig, manifest_file);
    case StepKind::kBoardImage:
      return ReadBoardImageStep(step, index, rig, manifest_file);
    case StepKind::kWhiteReference:
      return ReadWhiteReferenceStep(step, index, rig, manifest_file);
    case StepKind::kMirrorSphere:
      return ReadMirrorSphereStep(step, index, rig, manifest_file);
    case StepKind::kOther:
      break;
  }
  throw core::FormatError(
      manifest_file, "plan[" + std::to_string(index) + "].kind",
      "a step the rig runs (laser_calibration, btf_image, laser_sweep, board_image, white_reference or "
      "mirror_sphere)");
}

const std::vector<CameraFile>& Files(const CaptureStep& step) {
  return std::visit([](const auto& s) -> const std::vector<CameraFile>& { return s.files; }, step);
}

void CheckPlanSteps(const SessionManifest& manifest, const fs::path& manifest_file) {
  const auto runs = [](const PlannedStep& step) { return step.kind != StepKind::kOther; };
  if (std::none_of(manifest.plan.begin(), manifest.plan.end(), runs)) return;
  const RigDescription rig = ParseRigDescription(manifest.rig, manifest_file);
  for (std::size_t s = 0; s < manifest.plan.size(); ++s) {
    if (runs(manifest.plan[s])) ReadCaptureStep(manifest.plan[s], s, rig, manifest_file);
  }
}

}  // namespace mesocap::formats
