// `mesocap compress --in MATERIAL --out MATERIAL2 [--rank K | --max-error E]
// [--layout paper|per_texel] [--color rgb|ycbcr]`: factors the full BTF of any
// material package (a ground-truth one too) by SVD (Wang et al. 2005 Sec. 5)
// and writes a new package holding the factored BTF, with the MDF, ambient
// term and calibration copied through and the compression figures added to
// the error report.
#include <spdlog/spdlog.h>

#include <filesystem>
#include <map>

#include "apps/mesocap/command.h"
#include "core/error.h"
#include "core/material_package.h"
#include "processing/btf_compression.h"

namespace mesocap {
namespace {

struct CompressCommandOptions {
  std::filesystem::path in;
  std::filesystem::path out;
  BtfCompressionOptions compression;
  bool replace = false;
};

void RunCompress(const CompressCommandOptions& o) {
  if (const auto problem = o.compression.Check(); !problem.empty()) throw Error("compress: " + problem);
  const MaterialManifest manifest = ReadMaterialManifest(o.in);
  if (!manifest.full_btf) {
    throw Error("compress: " + o.in.string() + " holds no full BTF to factor (manifest.json has no btf.full)");
  }
  const FullBtf btf = ReadFullBtf(o.in, manifest);
  spdlog::info("compressing the {}x{} BTF of {} ({} views x {} lights), {} layout, {}", btf.width, btf.height,
               o.in.string(), btf.view_count(), btf.light_count(), ToString(o.compression.layout),
               ToString(o.compression.color));
  BtfCompressionReport report;
  const FactoredBtf factored = CompressBtf(btf, o.compression, &report);
  spdlog::info("rank {}: {}; measured relative RMS error {:.3g} ({:.2f} s)", report.rank, report.reason,
               report.measured_relative_rms_error, report.seconds);

  MaterialDescription description = manifest.description;
  description.provenance.software_version.clear();
  description.provenance.created_utc.clear();
  description.provenance.source = "compress of " + o.in.string() + " (" + manifest.description.provenance.source + ")";
  MaterialPackageWriter writer(o.out, description, o.replace);
  if (manifest.mdf) writer.WriteMdf(ReadMdf(o.in, manifest), manifest.mdf->forms);
  writer.WriteFactoredBtf(factored);
  if (manifest.ambient) writer.WriteAmbientTerm(ReadAmbientTerm(o.in, manifest));
  if (manifest.calibration) writer.WriteCalibration(ReadPackageCalibration(o.in, manifest));
  nlohmann::json errors = manifest.error_report ? ReadErrorReport(o.in, manifest) : nlohmann::json::object();
  errors["btf_compression"] = ToJson(report, factored);
  writer.WriteErrorReport(errors);
  writer.Commit();
  spdlog::info("wrote {}", o.out.string());
}

}  // namespace

void RegisterCompressCommand(CLI::App& app) {
  auto o = std::make_shared<CompressCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "compress", "Factor the full BTF of a material package by SVD into a new package (Wang et al. 2005 Sec. 5)");
  sub->add_option("--in", o->in, "material package holding a full BTF")->required()->check(CLI::ExistingDirectory);
  sub->add_option("--out", o->out, "material package folder to write")->required();
  auto* rank = sub->add_option("--rank", o->compression.rank, "number of SVD terms, 1..100")
                   ->check(CLI::Range(1, kMaxBtfRank));
  sub->add_option("--max-error", o->compression.max_relative_error,
                  "error budget: the smallest rank whose relative RMS error (of all RGB values) is at most this")
      ->check(CLI::Range(1e-12, 1.0))
      ->capture_default_str()
      ->excludes(rank);
  const std::map<std::string, BtfFactorLayout> layouts{{"paper", BtfFactorLayout::kPaper},
                                                       {"per_texel", BtfFactorLayout::kPerTexel}};
  sub->add_option("--layout", o->compression.layout,
                  "matrix layout: paper (rows x, y, light; columns view) or per_texel (rows x, y; columns view, light)")
      ->transform(CLI::CheckedTransformer(layouts, CLI::ignore_case))
      ->default_str("paper");
  const std::map<std::string, BtfFactorColor> colors{{"rgb", BtfFactorColor::kRgb}, {"ycbcr", BtfFactorColor::kYCbCr}};
  sub->add_option("--color", o->compression.color, "channels factored: rgb, or ycbcr (luminance/chroma)")
      ->transform(CLI::CheckedTransformer(colors, CLI::ignore_case))
      ->default_str("rgb");
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->callback([o] { RunCompress(*o); });
}

}  // namespace mesocap
