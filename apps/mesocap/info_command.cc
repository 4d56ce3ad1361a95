// `mesocap info PATH`: a readable summary of a calibration file, a rig
// description, a capture session folder, a material package folder or an
// image; `--json` prints one JSON object instead. Every reader validates, so
// `info` is also the quickest check that a file is sound.
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <tuple>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "calibration/calibration_board.h"
#include "calibration/nominal_geometry.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "formats/calibration.h"
#include "formats/capture_journal.h"
#include "formats/capture_session.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"
#include "formats/rig_description.h"
#include "mdf/displacement_image.h"
#include "pipelines/verify.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct InfoOptions {
  fs::path path;
  bool json = false;
};

json SetSummary(const core::SamplingSet& s) { return {{"name", s.name()}, {"count", s.size()}}; }

json MaterialInfo(const fs::path& dir) {
  const formats::MaterialManifest m = formats::ReadMaterialManifest(dir);
  const auto& d = m.description;
  json parts = json::object();
  if (m.mdf) {
    parts["mdf"] = {
        {"float32", m.mdf->forms.float32}, {"uint8", m.mdf->forms.uint8}, {"confidence", m.mdf->confidence}};
    if (m.mdf->forms.uint8) parts["mdf"]["scale_mm"] = m.mdf->scale_mm;
  }
  if (m.full_btf) parts["btf_full"] = true;
  if (m.factored_btf) {
    parts["btf_factored"] = {{"layout", ToString(m.factored_btf->layout)},
                             {"color", ToString(m.factored_btf->color)},
                             {"rank", m.factored_btf->rank}};
  }
  if (m.ambient) parts["ambient"] = true;
  if (m.error_report) parts["error_report"] = formats::ReadErrorReport(dir, m);
  if (m.calibration) {
    const formats::Calibration c = formats::ReadPackageCalibration(dir, m);
    parts["calibration"] = {
        {"cameras", c.cameras.size()}, {"lamps", c.lamps.size()}, {"laser_mounts", c.laser_mounts.size()}};
  }
  return {{"kind", "material"},
          {"path", dir.string()},
          {"name", d.name},
          {"texture_size", {d.width, d.height}},
          {"physical_size_mm", {d.physical_size_mm.x(), d.physical_size_mm.y()}},
          {"d_max_mm", d.d_max_mm},
          {"view_directions", SetSummary(d.view_directions)},
          {"light_directions", SetSummary(d.light_directions)},
          {"parts", parts},
          {"provenance",
           {{"software_version", d.provenance.software_version},
            {"created_utc", d.provenance.created_utc},
            {"source", d.provenance.source}}}};
}

json SessionInfo(const fs::path& dir) {
  const formats::SessionManifest m = formats::ReadSessionManifest(dir);
  pipelines::CheckSessionManifest(m, dir / formats::kSessionManifestName);
  std::map<std::string, int> kinds;
  for (const auto& s : m.plan) ++kinds[ToString(s.kind)];
  json out = {{"kind", "session"},
              {"path", dir.string()},
              {"rig", m.rig.value("name", "")},
              {"software_version", m.software_version},
              {"created_utc", m.created_utc},
              {"calibration", m.calibration ? json(*m.calibration) : json(nullptr)},
              {"planned_steps", m.plan.size()},
              {"planned_steps_by_kind", kinds}};
  const fs::path journal = dir / formats::kSessionJournalName;
  std::size_t done = 0;
  if (formats::JournalExists(journal)) {
    const formats::JournalContents j = formats::ReadCaptureJournal(journal, &m);
    done = formats::LatestRecords(j.records).size();  // a step done again counts once
    out["torn_tail_bytes"] = j.dropped_bytes;
  }
  out["completed_steps"] = done;
  out["complete"] = done == m.plan.size();
  out["contents"] = "not checked here; mesocap verify checks every file";
  out["version"] = m.version;
  return out;
}

json CalibrationInfo(const fs::path& file) {
  const formats::Calibration c = formats::ReadCalibration(file);
  json cameras = json::array();
  for (const auto& cam : c.cameras) {
    cameras.push_back(
        {{"id", cam.id},
         {"image_size", {cam.width, cam.height}},
         {"fx", cam.intrinsics.fx},
         {"fy", cam.intrinsics.fy},
         {"k1", cam.distortion.k1},
         {"position_mm",
          {cam.pose.transform.translation.x(), cam.pose.transform.translation.y(), cam.pose.transform.translation.z()}},
         {"has_uncertainty", cam.intrinsics.uncertainty.fx.has_value()},
         {"signal_per_radiance_second",
          cam.radiometry ? json(cam.radiometry->signal_per_radiance_second) : json(nullptr)}});
  }
  return {{"kind", "calibration"},
          {"path", file.string()},
          {"cameras", cameras},
          {"lamps", c.lamps.size()},
          {"laser_mounts", c.laser_mounts.size()},
          {"turntable_axis",
           {c.turntable.axis_direction.x(), c.turntable.axis_direction.y(), c.turntable.axis_direction.z()}}};
}

// Per laser location, the ray-plane sine with each camera (LaserRaySine), and
// the worst pair: a rig designer's check that no location's laser plane
// nearly contains a camera's rays (MDF triangulation rejects rays under
// TriangulationOptions::min_ray_plane_sine).
json LaserConditioning(const formats::RigDescription& r) {
  json sines = json::array();
  double worst = 2.0;
  int worst_camera = 0, worst_location = 0;
  for (int l = 0; l < static_cast<int>(r.laser.locations.size()); ++l) {
    json row = json::array();
    for (int c = 0; c < static_cast<int>(r.cameras.size()); ++c) {
      const double sine = calibration::LaserRaySine(r, c, l);
      row.push_back(std::round(sine * 1000) / 1000);
      if (sine < worst) std::tie(worst, worst_camera, worst_location) = std::tuple(sine, c, l);
    }
    sines.push_back(row);
  }
  return {{"laser_ray_sines", sines},
          {"smallest_laser_ray_sine",
           {{"sine", worst},
            {"camera", r.cameras[worst_camera].id},
            {"location", worst_location},
            {"below_triangulation_limit", worst < mdf::TriangulationOptions{}.min_ray_plane_sine}}}};
}

json RigInfo(const fs::path& file) {
  const formats::RigDescription r = formats::ReadRigDescription(file);
  const auto board = calibration::RigCalibrationBoard(r);
  json info = {{"kind", "rig"},
               {"path", file.string()},
               {"name", r.name},
               {"sample_size_mm", r.sample_size_mm},
               {"cameras", r.cameras.size()},
               {"camera_image_size", {r.cameras[0].width, r.cameras[0].height}},
               {"views", r.view_count()},
               {"lights", r.light_count()},
               {"laser_locations", r.laser.locations.size()},
               {"frames_per_sweep", r.laser.frames_per_sweep},
               {"calibration_board", board ? json(board->Spec()) : json(nullptr)}};
  info.update(LaserConditioning(r));
  return info;
}

json ImageInfo(const fs::path& file) {
  const core::ImageHeader h = core::ReadImageHeader(file);
  // Every pixel decoded, so that a file cut short is found here too.
  (void)core::ReadImage(file);
  return {{"kind", "image"},    {"path", file.string()},  {"width", h.width},
          {"height", h.height}, {"channels", h.channels}, {"encoding", ToString(h.encoding)}};
}

// The "format" member every mesocap JSON file carries.
std::string FormatOf(const fs::path& file) {
  const json doc = core::ReadJsonFile(file);
  return core::JsonFieldReader(doc, file).String("format");
}

json Describe(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw core::Error(path.string() + ": no such file or folder");
  if (fs::is_directory(path, ec)) {
    const fs::path manifest = path / "manifest.json";
    if (!fs::exists(manifest, ec)) {
      throw core::Error(path.string() + ": not a capture session or material package (no manifest.json)");
    }
    const std::string format = FormatOf(manifest);
    if (format == "mesocap.material") return MaterialInfo(path);
    if (format == "mesocap.session") return SessionInfo(path);
    throw core::FormatError(manifest, "format",
                            "expected \"mesocap.material\" or \"mesocap.session\", got " + core::Quoted(format));
  }
  if (path.extension() == ".json") {
    const std::string format = FormatOf(path);
    if (format == "mesocap.calibration") return CalibrationInfo(path);
    if (format == "mesocap.rig") return RigInfo(path);
    throw core::FormatError(path, "format",
                            "expected \"mesocap.calibration\" or \"mesocap.rig\", got " + core::Quoted(format));
  }
  return ImageInfo(path);
}

void PrintText(const json& j) {
  const std::string kind = j["kind"];
  std::cout << kind << " " << j["path"].get<std::string>() << "\n";
  for (const auto& [key, value] : j.items()) {
    if (key == "kind" || key == "path") continue;
    if (key == "cameras" && value.is_array()) {
      for (const auto& cam : value) {
        std::cout << "  camera " << cam["id"].get<std::string>() << ": " << cam["image_size"][0] << "x"
                  << cam["image_size"][1] << " px, fx " << cam["fx"] << " fy " << cam["fy"] << ", k1 " << cam["k1"]
                  << ", gain "
                  << (cam["signal_per_radiance_second"].is_null() ? "not calibrated"
                                                                  : cam["signal_per_radiance_second"].dump())
                  << "\n";
      }
      continue;
    }
    std::cout << "  " << key << ": " << (value.is_string() ? value.get<std::string>() : value.dump()) << "\n";
  }
}

void RunInfo(const InfoOptions& options) {
  const json summary = Describe(options.path);
  if (options.json) {
    std::cout << summary.dump(2) << "\n";
  } else {
    PrintText(summary);
  }
}

}  // namespace

void RegisterInfoCommand(CLI::App& app) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* sub = app.add_subcommand("info", HelpText("info"));
  sub->add_option("path", options->path, "file or folder to describe")->required();
  sub->add_flag("--json", options->json, "print one JSON object instead of text");
  sub->callback([options] { RunInfo(*options); });
}

}  // namespace mesocap
