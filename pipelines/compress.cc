#include "pipelines/compress.h"

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "formats/package_full_btf_reader.h"

namespace mesocap::pipelines {

core::CheckResult CompressOptions::Check() const {
  if (in.empty()) return "in: give the material package holding a full BTF";
  if (out.empty()) return "out: give the material package folder to write";
  return compression.Check();
}

btf::BtfCompressionReport RunCompress(const CompressOptions& o) {
  core::ThrowIfInvalid(o.Check(), "compress");
  core::ExpectReplaceable(o.out, formats::PackageReplacement(o.replace, {o.in}));
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(o.in);
  if (!manifest.full_btf) {
    throw core::Error("compress: " + o.in.string() + " holds no full BTF to factor (manifest.json has no btf.full)");
  }
  formats::PackageFullBtfReader btf(o.in, manifest);
  spdlog::info("compressing the {}x{} BTF of {} ({} views x {} lights)", btf.width(), btf.height(), o.in.string(),
               btf.view_count(), btf.light_count());
  btf::BtfCompressionReport report;
  const core::FactoredBtf factored = btf::CompressBtf(btf, o.compression, &report);
  if (!report.representation_reason.empty()) spdlog::info("{}", report.representation_reason);
  spdlog::info("{} {}, rank {}: {}; measured relative RMS error {:.3g}, {} bytes ({:.2f} s)", ToString(factored.layout),
               ToString(factored.color), report.rank, report.reason, report.measured_relative_rms_error,
               report.factor_bytes, report.seconds);

  formats::MaterialDescription description = manifest.description;
  description.provenance.software_version.clear();
  description.provenance.created_utc.clear();
  description.provenance.source = "compress of " + o.in.string() + " (" + manifest.description.provenance.source + ")";
  formats::MaterialPackageWriter writer(o.out, description, o.replace, {o.in});
  if (manifest.mdf) writer.WriteMdf(formats::ReadMdf(o.in, manifest), manifest.mdf->forms);
  writer.WriteFactoredBtf(factored);
  if (manifest.ambient) writer.WriteAmbientTerm(formats::ReadAmbientTerm(o.in, manifest));
  if (manifest.calibration) writer.WriteCalibration(formats::ReadPackageCalibration(o.in, manifest));
  nlohmann::json errors = manifest.error_report ? formats::ReadErrorReport(o.in, manifest) : nlohmann::json::object();
  errors["btf_compression"] = ToJson(report, factored);
  writer.WriteErrorReport(errors);
  writer.Commit();
  return report;
}

}  // namespace mesocap::pipelines
