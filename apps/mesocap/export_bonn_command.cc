// `mesocap export bonn --in MATERIAL --out PATH --form ubo2003|fmf|dfmf`:
// writes a material package's BTF in a Bonn BTF database form
// (pipelines/export_bonn.h): the UBO2003 image folder (8-bit sRGB PNG or
// linear half EXR), or the UBO2014 binary FMF / DFMF file that btflib reads.
#include <spdlog/spdlog.h>

#include <map>
#include <string>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "pipelines/export_bonn.h"

namespace mesocap {

void RegisterExportBonnCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::ExportBonnOptions>();
  CLI::App* group = GroupCommand(app, "export", "Write a material package in another tool's format");
  CLI::App* sub = group->add_subcommand("bonn", HelpText("export_bonn"));
  sub->add_option("--in", o->in, "material package holding a BTF (full or factored)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--out", o->out, "folder (ubo2003) or file (fmf, dfmf) to write")->required();
  const std::map<std::string, bonn::BonnForm> forms{
      {"ubo2003", bonn::BonnForm::kUbo2003}, {"fmf", bonn::BonnForm::kFmf}, {"dfmf", bonn::BonnForm::kDfmf}};
  sub->add_option("--form", o->form,
                  "ubo2003 (image folder tl..._pl..._tv..._pv...), fmf (!FMF12FCER) or dfmf (!DFMF08FCR)")
      ->required()
      ->transform(NamedChoice(forms));
  const std::map<std::string, bonn::Ubo2003Encoding> encodings{{"png", bonn::Ubo2003Encoding::kSrgb8Png},
                                                               {"exr", bonn::Ubo2003Encoding::kHalfExr}};
  sub->add_option("--encoding", o->encoding, "ubo2003 images: png (8-bit sRGB) or exr (linear half)")
      ->transform(NamedChoice(encodings))
      ->default_str("png");
  sub->add_option("--scale", o->scale, "ubo2003 images: image value = reflectance x scale")
      ->check(InRange(bonn::kMinUbo2003Scale, bonn::kMaxUbo2003Scale))
      ->capture_default_str();
  const std::map<std::string, bonn::BonnScalar> scalars{{"half", bonn::BonnScalar::kHalf},
                                                        {"float", bonn::BonnScalar::kFloat}};
  sub->add_option("--scalar", o->scalar, "fmf/dfmf factor values: half (as btflib writes) or float")
      ->transform(NamedChoice(scalars))
      ->default_str("half");
  auto* rank =
      sub->add_option("--rank", o->compression.rank, "fmf/dfmf when factoring here: number of SVD components, 1..100")
          ->check(InRange(1, core::kMaxBtfRank));
  sub->add_option("--max-error", o->compression.max_relative_error,
                  "fmf/dfmf when factoring here: the smallest rank whose relative RMS error is at most this")
      ->check(InRange(1e-12, 1.0))
      ->capture_default_str()
      ->excludes(rank);
  const std::map<std::string, core::BtfFactorColor> colors{{"rgb", core::BtfFactorColor::kRgb},
                                                           {"ycbcr", core::BtfFactorColor::kYCbCr}};
  sub->add_option_function<core::BtfFactorColor>(
         "--color", [o](const core::BtfFactorColor& color) { o->compression.color = color; },
         "dfmf when factoring here: rgb (colour model 0) or ycbcr (written as the PCA model 3)")
      ->transform(NamedChoice(colors))
      ->default_str("rgb");
  sub->add_flag("--replace", o->replace, "replace an existing file or folder at --out");
  sub->callback([o] {
    const pipelines::ExportBonnReport r = pipelines::RunExportBonn(*o);
    if (r.compression) {
      spdlog::info("factored to rank {} ({}); relative RMS error {:.3g}", r.compression->rank, r.compression->reason,
                   r.compression->measured_relative_rms_error);
    }
    spdlog::info("wrote {} ({}, from the {}{}; {} file(s), {:.2f} s)", o->out.string(), ToString(o->form), r.source,
                 r.rank > 0 ? ", " + std::to_string(r.rank) + " components" : std::string(), r.files, r.seconds);
  });
}

}  // namespace mesocap
