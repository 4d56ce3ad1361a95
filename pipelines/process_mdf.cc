#include "pipelines/process_mdf.h"

#include <algorithm>
#include <cmath>

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "formats/calibration.h"
#include "formats/captured_session.h"
#include "formats/material_manifest.h"
#include "formats/material_package_writer.h"

namespace mesocap::pipelines {

namespace fs = std::filesystem;

core::CheckResult ProcessMdfOptions::Check() const {
  if (session.empty()) return "session: give the capture session folder";
  if (out.empty()) return "out: give the material package folder to write";
  return processing.Check();
}

ProcessMdfReport RunProcessMdf(const ProcessMdfOptions& o) {
  core::ThrowIfInvalid(o.Check(), "process mdf");
  core::ExpectReplaceable(o.out, formats::PackageReplacement(o.replace, {o.session, o.calibration}));
  const formats::CapturedSession session(o.session, {o.allow_incomplete, "process mdf"});
  if (!session.missing_steps().empty()) {
    spdlog::warn("{}: leaving out {} of {} planned steps, which the journal lacks (--allow-incomplete)",
                 o.session.string(), session.missing_steps().size(), session.manifest().plan.size());
  }
  const fs::path calibration_file = o.calibration.empty() ? session.IntactCalibrationFile() : o.calibration;
  const formats::Calibration calibration = formats::ReadCalibration(calibration_file);
  const mdf::MdfProcessingResult result = mdf::ProcessMdfSession(session, calibration, o.processing);
  formats::MaterialDescription description;
  description.name = o.out.filename().string();
  description.width = description.height = o.processing.texture_size;
  description.physical_size_mm = {result.sample_size_mm, result.sample_size_mm};
  // The slab's depth: given, or the deepest measured point rounded up to
  // 0.1 mm (the 8-bit scale follows the largest distance either way).
  description.d_max_mm = o.d_max_mm > 0 ? o.d_max_mm : std::max(0.1, std::ceil(result.deepest_mm * 10.0) / 10.0);
  description.view_directions = result.mdf.views;
  description.light_directions = result.light_directions;
  description.provenance.source = "process mdf session=" + o.session.string();
  formats::MaterialPackageWriter writer(o.out, description, o.replace, {o.session, calibration_file});
  writer.WriteMdf(result.mdf);
  writer.WriteMdfConfidence(result.confidence);
  writer.WriteCalibration(calibration);
  writer.Commit();
  return {result.sweeps, description.width, result.mdf.view_count(), result.laser_planes,
          result.worst_plane_height_sigma_mm};
}

}  // namespace mesocap::pipelines
