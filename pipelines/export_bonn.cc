#include "pipelines/export_bonn.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "core/atomic_file.h"
#include "core/version.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"

namespace mesocap::pipelines {
namespace {

namespace fs = std::filesystem;

// The meta data a Bonn file takes from a package's description.
void FillBonnMeta(const formats::MaterialDescription& d, bonn::BonnBtfFile* b) {
  b->measurement_setup = (std::string("mesocap ") + core::Version() + ": " + d.name).substr(0, 80);
  b->pixels_per_mm = static_cast<float>(d.width / d.physical_size_mm.x());
}

// The package's BTF in full, read or reconstructed from its factors.
core::FullBtf FullBtfOfPackage(const fs::path& package, const formats::MaterialManifest& manifest) {
  if (manifest.full_btf) return formats::ReadFullBtf(package, manifest);
  const core::FactoredBtf factored = formats::ReadFactoredBtf(package, manifest);
  core::FullBtf full = core::MakeFullBtf(factored.width, factored.height, factored.views, factored.lights);
  for (int v = 0; v < full.view_count(); ++v) full.view_images[v] = btf::ReconstructBtfView(factored, v);
  return full;
}

// Only what this command writes is replaced, never the package it reads.
core::OutputReplacement ExportReplacement(const ExportBonnOptions& o) {
  if (o.form == bonn::BonnForm::kUbo2003) {
    return {
        o.replace, "a UBO2003 image folder (only tl..._pl..._tv..._pv... images)", bonn::IsUbo2003ExportFolder, {o.in}};
  }
  return {o.replace, "a Bonn BTF file (FMF or DFMF)", bonn::IsBonnBtfFile, {o.in}};
}

// The UBO2003 image folder, one view at a time.
void ExportUbo2003(const ExportBonnOptions& o, const formats::MaterialManifest& manifest, ExportBonnReport* report) {
  const formats::MaterialDescription& d = manifest.description;
  report->source = manifest.full_btf ? "full BTF" : "factored BTF, reconstructed";
  std::optional<core::FactoredBtf> factored;
  if (!manifest.full_btf) factored = formats::ReadFactoredBtf(o.in, manifest);
  core::AtomicDirectory folder(o.out, ExportReplacement(o));
  for (int v = 0; v < d.view_directions.size(); ++v) {
    const core::Image view =
        factored ? btf::ReconstructBtfView(*factored, v) : formats::ReadFullBtfView(o.in, manifest, v);
    report->clipped_values +=
        bonn::WriteUbo2003View(folder.temp_path(), d.view_directions, d.light_directions, v, view, o.encoding, o.scale);
  }
  folder.Commit();
  report->files = static_cast<long long>(d.view_directions.size()) * d.light_directions.size();
  if (report->clipped_values > 0) {
    spdlog::warn(
        "{} of {} values fell outside [0, 1] after scaling by {} and were clipped to 8 bits; "
        "choose --scale so the brightest value maps to at most 1, or write EXR",
        report->clipped_values, report->files * d.width * d.height * 3, o.scale);
  }
}

// A UBO2014 FMF or DFMF file, factored here unless the package holds a
// per_texel factored BTF (what a DFMF stores as it is).
void ExportBonnFile(const ExportBonnOptions& o, const formats::MaterialManifest& manifest, ExportBonnReport* report) {
  core::RemoveStaleTemporariesOf(o.out);
  bonn::BonnBtfFile file;
  if (o.form == bonn::BonnForm::kDfmf) {
    if (manifest.factored_btf && manifest.factored_btf->layout == core::BtfFactorLayout::kPerTexel) {
      report->source = "per_texel factored BTF";
      file = bonn::BonnDfmfFromFactored(formats::ReadFactoredBtf(o.in, manifest));
    } else {
      report->source = manifest.full_btf ? "full BTF, factored per_texel"
                                         : std::string(ToString(manifest.factored_btf->layout)) +
                                               "-layout factors, refactored per_texel";
      btf::BtfCompressionOptions per_texel = o.compression;
      per_texel.layout = core::BtfFactorLayout::kPerTexel;
      btf::BtfCompressionReport compression;
      file = bonn::BonnDfmfFromFactored(btf::CompressBtf(FullBtfOfPackage(o.in, manifest), per_texel, &compression));
      report->compression = compression;
    }
  } else {
    report->source = manifest.full_btf ? "full BTF, factored as one matrix" : "factored BTF, refactored as one matrix";
    btf::BtfCompressionReport compression;
    file = bonn::BonnFmfFromFullBtf(FullBtfOfPackage(o.in, manifest), o.compression, &compression);
    report->compression = compression;
  }
  FillBonnMeta(manifest.description, &file);
  if (file.view_count() != file.light_count()) {
    spdlog::warn(
        "{}: {} views and {} lights; the Free BTF Library (btf.hh, which btf-extractor uses) reads only "
        "files with as many views as lights, btflib reads this one",
        o.out.string(), file.view_count(), file.light_count());
  }
  report->rank = 0;
  for (const auto& f : file.factors) report->rank = std::max(report->rank, f.rank());
  bonn::WriteBonnBtfFile(o.out, file, o.scalar);
  report->files = 1;
}

}  // namespace

core::CheckResult ExportBonnOptions::Check() const {
  if (in.empty()) return "in: give the material package to export";
  if (out.empty()) return "out: give the folder (ubo2003) or file (fmf, dfmf) to write";
  if (!(scale >= bonn::kMinUbo2003Scale && scale <= bonn::kMaxUbo2003Scale)) {
    std::ostringstream problem;
    problem << "scale (--scale) " << scale << " must be in [" << bonn::kMinUbo2003Scale << ", "
            << bonn::kMaxUbo2003Scale << "]";
    return problem.str();
  }
  if (scalar == bonn::BonnScalar::kDouble) return "mesocap writes half or float factors";
  return compression.Check();
}

ExportBonnReport RunExportBonn(const ExportBonnOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  core::ThrowIfInvalid(o.Check(), "export bonn");
  core::ExpectReplaceable(o.out, ExportReplacement(o));
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(o.in);
  if (!manifest.full_btf && !manifest.factored_btf) {
    throw core::Error("export bonn: " + o.in.string() + " holds no BTF (manifest.json has no btf part)");
  }
  ExportBonnReport report;
  if (o.form == bonn::BonnForm::kUbo2003) {
    ExportUbo2003(o, manifest, &report);
  } else {
    ExportBonnFile(o, manifest, &report);
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace mesocap::pipelines
