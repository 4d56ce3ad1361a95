#include "btf/material_compression.h"

#include <spdlog/spdlog.h>

#include "core/error.h"
#include "formats/material_manifest.h"
#include "formats/material_package.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "formats/package_full_btf_reader.h"

namespace mesocap::btf {

BtfCompressionReport CompressMaterialPackage(const std::filesystem::path& in, const std::filesystem::path& out,
                                             const BtfCompressionOptions& options, bool replace) {
  if (const auto problem = options.Check(); !problem.empty()) throw core::Error("compress: " + problem);
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(in);
  if (!manifest.full_btf) {
    throw core::Error("compress: " + in.string() + " holds no full BTF to factor (manifest.json has no btf.full)");
  }
  // Streamed from the view files: the BTF is never whole in memory.
  formats::PackageFullBtfReader btf(in, manifest);
  spdlog::info("compressing the {}x{} BTF of {} ({} views x {} lights), {} layout, {}", btf.width(), btf.height(),
               in.string(), btf.view_count(), btf.light_count(), ToString(options.layout), ToString(options.color));
  BtfCompressionReport report;
  const core::FactoredBtf factored = CompressBtf(btf, options, &report);
  spdlog::info("rank {}: {}; measured relative RMS error {:.3g} ({:.2f} s)", report.rank, report.reason,
               report.measured_relative_rms_error, report.seconds);

  formats::MaterialDescription description = manifest.description;
  description.provenance.software_version.clear();
  description.provenance.created_utc.clear();
  description.provenance.source = "compress of " + in.string() + " (" + manifest.description.provenance.source + ")";
  formats::MaterialPackageWriter writer(out, description, replace);
  if (manifest.mdf) writer.WriteMdf(formats::ReadMdf(in, manifest), manifest.mdf->forms);
  writer.WriteFactoredBtf(factored);
  if (manifest.ambient) writer.WriteAmbientTerm(formats::ReadAmbientTerm(in, manifest));
  if (manifest.calibration) writer.WriteCalibration(formats::ReadPackageCalibration(in, manifest));
  nlohmann::json errors = manifest.error_report ? formats::ReadErrorReport(in, manifest) : nlohmann::json::object();
  errors["btf_compression"] = ToJson(report, factored);
  writer.WriteErrorReport(errors);
  writer.Commit();
  return report;
}

}  // namespace mesocap::btf
