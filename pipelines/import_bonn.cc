#include "pipelines/import_bonn.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <sstream>

#include "btf/ambient_term.h"
#include "core/atomic_file.h"
#include "core/mdf.h"
#include "formats/material_manifest.h"
#include "formats/material_package_writer.h"
#include "interop/bonn/bonn_btf_file.h"
#include "interop/bonn/bonn_ubo2003.h"

namespace mesocap::pipelines {
namespace {

namespace fs = std::filesystem;

formats::MaterialDescription DescriptionFor(const std::string& name, int width, int height, double width_mm,
                                            double d_max_mm, core::SamplingSet views, core::SamplingSet lights,
                                            std::string source) {
  formats::MaterialDescription d;
  d.name = name;
  d.width = width;
  d.height = height;
  d.physical_size_mm = {width_mm, width_mm * height / width};
  d.d_max_mm = d_max_mm;
  d.view_directions = std::move(views);
  d.light_directions = std::move(lights);
  d.provenance.source = std::move(source);
  return d;
}

void WriteFlatMdf(const formats::MaterialDescription& d, formats::MaterialPackageWriter* writer) {
  core::Mdf mdf = core::MakeMdf(d.width, d.height, d.view_directions);
  std::fill(mdf.distance_mm.data(), mdf.distance_mm.data() + mdf.distance_mm.size(), 0.0f);
  writer->WriteMdf(mdf);
}

// The UBO2003 image folder: a full BTF only.
void ImportUbo2003(const ImportBonnOptions& o, const std::string& name, ImportBonnReport* report) {
  report->form = bonn::BonnForm::kUbo2003;
  const BonnImportParts parts = o.parts.value_or(BonnImportParts::kFull);
  if (parts != BonnImportParts::kFull) {
    throw core::Error("import bonn: " + o.in.string() +
                      " is an image folder, which holds a full BTF only; import it "
                      "with --btf full and factor it with `mesocap compress`");
  }
  if (!(o.width_mm > 0.0)) {
    throw core::Error("import bonn: the images of " + o.in.string() + " carry no physical size; give --size-mm");
  }
  const bonn::Ubo2003ImageSet set = bonn::ScanUbo2003Folder(o.in);
  const formats::MaterialDescription d = DescriptionFor(name, set.width, set.height, o.width_mm, o.d_max_mm, set.views,
                                                        set.lights, "import bonn ubo2003 " + o.in.string());
  formats::MaterialPackageWriter writer(o.out, d, o.replace, {o.in});
  formats::AmbientTerm ambient = btf::MakeAmbientTerm(d.width, d.height, d.view_directions);
  for (int v = 0; v < d.view_directions.size(); ++v) {
    const core::Image view = bonn::ReadUbo2003View(set, v, o.scale);
    writer.WriteFullBtfView(v, view);
    btf::AddAmbientView(view, d.light_directions, v, &ambient);
  }
  writer.WriteAmbientTerm(ambient);
  if (o.flat_mdf) WriteFlatMdf(d, &writer);
  const nlohmann::json facts = {
      {"form", "ubo2003"}, {"images", d.view_directions.size() * d.light_directions.size()}, {"scale", o.scale}};
  writer.WriteErrorReport({{"bonn_import", facts}});
  report->manifest = writer.Commit();
}

// A UBO2014 FMF or DFMF file: factored (exactly), full (decoded as btflib
// decodes it) or both.
void ImportBonnFile(const ImportBonnOptions& o, const std::string& name, ImportBonnReport* report) {
  const bonn::BonnBtfFile btf = bonn::ReadBonnBtfFile(o.in);
  report->form = btf.form == bonn::BonnBtfForm::kFmf ? bonn::BonnForm::kFmf : bonn::BonnForm::kDfmf;
  report->signature = btf.signature;
  const BonnImportParts parts = o.parts.value_or(BonnImportParts::kFactored);
  double width_mm = o.width_mm;
  if (!(width_mm > 0.0)) {
    if (!(btf.pixels_per_mm > 0.0f)) {
      throw core::FormatError(
          o.in, "meta.pixels_per_mm",
          "is " + std::to_string(btf.pixels_per_mm) + ", so the physical size is unknown; give --size-mm");
    }
    width_mm = btf.width / static_cast<double>(btf.pixels_per_mm);
  }
  if (btf.rgb_scale_factor != Eigen::Vector3f::Ones()) {
    spdlog::warn("{}: RGB scale factor ({}, {}, {}) is not applied (btflib does not apply it either)", o.in.string(),
                 btf.rgb_scale_factor[0], btf.rgb_scale_factor[1], btf.rgb_scale_factor[2]);
  }
  std::optional<core::FactoredBtf> factored;
  if (parts != BonnImportParts::kFull) factored = bonn::FactoredFromBonn(btf, o.in);
  try {
    bonn::BonnToRgb(btf);  // a full import needs a linear colour model too: fail before writing anything
  } catch (const core::Error& e) {
    throw core::FormatError(o.in, "color_model", e.what());
  }
  const formats::MaterialDescription d = DescriptionFor(
      name, btf.width, btf.height, width_mm, o.d_max_mm, bonn::BonnViewSet(btf, o.in), bonn::BonnLightSet(btf, o.in),
      std::string("import bonn ") + ToString(report->form) + " " + o.in.string());
  formats::MaterialPackageWriter writer(o.out, d, o.replace, {o.in});
  formats::AmbientTerm ambient = btf::MakeAmbientTerm(d.width, d.height, d.view_directions);
  for (int v = 0; v < d.view_directions.size(); ++v) {
    // With a full BTF the ambient term integrates the exact decode; else
    // the factored BTF, which equals it up to float rounding.
    const core::Image view =
        parts != BonnImportParts::kFactored ? bonn::BonnBtfView(btf, v) : btf::ReconstructBtfView(*factored, v);
    if (parts != BonnImportParts::kFactored) writer.WriteFullBtfView(v, view);
    btf::AddAmbientView(view, d.light_directions, v, &ambient);
  }
  if (factored) {
    writer.WriteFactoredBtf(*factored);
    report->rank = factored->rank();
  }
  writer.WriteAmbientTerm(ambient);
  if (o.flat_mdf) WriteFlatMdf(d, &writer);
  const nlohmann::json facts = {{"form", ToString(report->form)},
                                {"signature", btf.signature},
                                {"scalar_bytes", static_cast<int>(btf.scalar)},
                                {"color_model", bonn::BonnColorModelName(btf.color_model)},
                                {"cosine_flag", btf.cosine_flag}};
  writer.WriteErrorReport({{"bonn_import", facts}});
  report->manifest = writer.Commit();
}

}  // namespace

core::CheckResult ImportBonnOptions::Check() const {
  if (in.empty()) return "in: give the image folder or FMF/DFMF file to import";
  if (out.empty()) return "out: give the material package folder to write";
  std::ostringstream problem;
  if (!(d_max_mm >= kMinBonnLengthMm && d_max_mm <= kMaxBonnDMaxMm)) {
    problem << "d_max_mm (--d-max-mm) " << d_max_mm << " must be in [" << kMinBonnLengthMm << ", " << kMaxBonnDMaxMm
            << "] mm (the Bonn forms carry no depth)";
  } else if (!(width_mm == 0.0 || (width_mm >= kMinBonnLengthMm && width_mm <= kMaxBonnWidthMm))) {
    problem << "width_mm (--size-mm) " << width_mm << " must be 0 (from the file) or in [" << kMinBonnLengthMm << ", "
            << kMaxBonnWidthMm << "] mm";
  } else if (!(scale >= bonn::kMinUbo2003Scale && scale <= bonn::kMaxUbo2003Scale)) {
    problem << "scale (--scale) " << scale << " must be in [" << bonn::kMinUbo2003Scale << ", "
            << bonn::kMaxUbo2003Scale << "]";
  }
  return problem.str();
  return {};
}

ImportBonnReport RunImportBonn(const ImportBonnOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  core::ThrowIfInvalid(o.Check(), "import bonn");
  core::ExpectReplaceable(o.out, formats::PackageReplacement(o.replace, {o.in}));
  std::error_code ec;
  fs::path named = o.in;
  if (named.filename().empty()) named = named.parent_path();  // "folder/"
  const bool folder = fs::is_directory(o.in, ec);
  const std::string name = !o.name.empty() ? o.name : folder ? named.filename().string() : named.stem().string();
  ImportBonnReport report;
  if (folder) {
    ImportUbo2003(o, name, &report);
  } else {
    ImportBonnFile(o, name, &report);
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace mesocap::pipelines
