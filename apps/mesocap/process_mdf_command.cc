// `mesocap process mdf --session S --calibration C --out MATERIAL`: the 4D
// MDF of a capture session's laser scans (MDF paper Sec. 3.2), written in
// float and 8-bit form (Sec. 5) into a new material package. Everything is
// computed before the package is written, so bad input leaves nothing.
#include <spdlog/spdlog.h>

#include <filesystem>
#include <memory>

#include "apps/mesocap/command.h"
#include "calibration/nominal_geometry.h"
#include "core/error.h"
#include "formats/calibration.h"
#include "formats/capture_session.h"
#include "formats/material_manifest.h"
#include "formats/material_package_writer.h"
#include "formats/rig_description.h"
#include "mdf/mdf_session.h"

namespace mesocap {
namespace {

struct ProcessMdfOptions {
  std::filesystem::path session;
  std::filesystem::path calibration;
  std::filesystem::path out;
  double d_max_mm = 0;  // 0: the deepest measured point
  bool replace = false;
  mdf::MdfProcessingOptions processing;
};

void RunProcessMdf(const ProcessMdfOptions& o) {
  if (!o.replace && std::filesystem::exists(o.out)) {
    throw core::Error("process mdf: " + o.out.string() + " exists (use --replace to replace it)");
  }
  const formats::Calibration calibration = formats::ReadCalibration(o.calibration);
  const mdf::MdfProcessingResult result = mdf::ProcessMdfSession(o.session, calibration, o.processing);
  const formats::SessionManifest manifest = formats::ReadSessionManifest(o.session);
  const formats::RigDescription rig =
      formats::ParseRigDescription(manifest.rig, o.session / formats::kSessionManifestName);
  formats::MaterialDescription description;
  description.name = o.out.filename().string();
  description.width = description.height = o.processing.texture_size;
  description.physical_size_mm = {result.sample_size_mm, result.sample_size_mm};
  // The slab's depth: given, or the deepest measured point rounded up to
  // 0.1 mm (the 8-bit scale follows the largest distance either way).
  description.d_max_mm = o.d_max_mm > 0 ? o.d_max_mm : std::max(0.1, std::ceil(result.deepest_mm * 10.0) / 10.0);
  description.view_directions = result.mdf.views;
  description.light_directions = calibration::LightDirections(rig);
  description.provenance.source = "process mdf session=" + o.session.string();
  formats::MaterialPackageWriter writer(o.out, description, o.replace);
  writer.WriteMdf(result.mdf);
  writer.WriteMdfConfidence(result.confidence);
  writer.WriteCalibration(calibration);
  writer.Commit();
  spdlog::info("wrote {}: {} sweeps, {}x{} texels x {} views", o.out.string(), result.sweeps, description.width,
               description.height, result.mdf.view_count());
}

}  // namespace

void RegisterProcessMdfCommand(CLI::App& app) {
  auto o = std::make_shared<ProcessMdfOptions>();
  CLI::App* group = GroupCommand(app, "process", "Process a capture session into material package parts");
  CLI::App* sub = group->add_subcommand("mdf", "The MDF from a session's laser scans (space-time analysis)");
  sub->add_option("--session", o->session, "capture session folder")->required();
  sub->add_option("--calibration", o->calibration, "rig calibration file")->required();
  sub->add_option("--out", o->out, "material package folder to write")->required();
  sub->add_option("--texture-size", o->processing.texture_size, "texels per side")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  sub->add_option("--locations", o->processing.locations, "laser locations to use (indices; default all)");
  sub->add_option("--threshold", o->processing.space_time.threshold,
                  "space-time peak threshold (fraction of full scale) below which a pixel is unknown")
      ->capture_default_str();
  sub->add_option("--d-max-mm", o->d_max_mm, "slab depth of the package (default: deepest measured point)");
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->callback([o] { RunProcessMdf(*o); });
}

}  // namespace mesocap
