// `mesocap compress --in MATERIAL --out MATERIAL2 [--rank K | --max-error E]
// [--layout paper|per_texel] [--color rgb|ycbcr]`: factors the full BTF of any
// material package (a ground-truth one too) by SVD (Wang et al. 2005 Sec. 5)
// into a new package (pipelines/compress.h).
#include <spdlog/spdlog.h>

#include <map>

#include "apps/mesocap/command.h"
#include "pipelines/compress.h"

namespace mesocap {

void RegisterCompressCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::CompressOptions>();
  CLI::App* sub = app.add_subcommand(
      "compress", "Factor the full BTF of a material package by SVD into a new package (Wang et al. 2005 Sec. 5)");
  sub->add_option("--in", o->in, "material package holding a full BTF")->required()->check(CLI::ExistingDirectory);
  sub->add_option("--out", o->out, "material package folder to write")->required();
  auto* rank = sub->add_option("--rank", o->compression.rank, "number of SVD terms, 1..100")
                   ->check(InRange(1, core::kMaxBtfRank));
  sub->add_option("--max-error", o->compression.max_relative_error,
                  "error budget: the smallest rank whose relative RMS error (of all RGB values) is at most this")
      ->check(InRange(1e-12, 1.0))
      ->capture_default_str()
      ->excludes(rank);
  const std::map<std::string, core::BtfFactorLayout> layouts{{"paper", core::BtfFactorLayout::kPaper},
                                                             {"per_texel", core::BtfFactorLayout::kPerTexel}};
  sub->add_option("--layout", o->compression.layout,
                  "matrix layout: paper (rows x, y, light; columns view) or per_texel (rows x, y; columns view, light)")
      ->transform(CLI::CheckedTransformer(layouts, CLI::ignore_case))
      ->default_str("paper");
  const std::map<std::string, core::BtfFactorColor> colors{{"rgb", core::BtfFactorColor::kRgb},
                                                           {"ycbcr", core::BtfFactorColor::kYCbCr}};
  sub->add_option("--color", o->compression.color, "channels factored: rgb, or ycbcr (luminance/chroma)")
      ->transform(CLI::CheckedTransformer(colors, CLI::ignore_case))
      ->default_str("rgb");
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->callback([o] {
    pipelines::RunCompress(*o);
    spdlog::info("wrote {}", o->out.string());
  });
}

}  // namespace mesocap
