// `mesocap compress --in MATERIAL --out MATERIAL2 [--rank K | --max-error E |
// --max-bytes B] [--layout auto|paper|per_texel|clustered] [--clusters N] [--color auto|rgb|ycbcr]`:
// factors the full BTF of any material package (a ground-truth one too) by
// SVD (Wang et al. 2005 Sec. 5) into a new package (pipelines/compress.h),
// in the representation that meets the budget in the fewest bytes.
#include <spdlog/spdlog.h>

#include "apps/mesocap/command.h"
#include "apps/mesocap/compression_options.h"
#include "pipelines/compress.h"

namespace mesocap {

void RegisterCompressCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::CompressOptions>();
  CLI::App* sub = app.add_subcommand(
      "compress",
      "Factor the full BTF of a material package by SVD into a new package (Wang et al. 2005 Sec. 5)\n\n"
      "The MDF, ambient term and calibration are copied through. The representation (--layout, --color; "
      "clustered is local PCA, Mueller et al. 2003: texels grouped by k-means, each group factored on its own; "
      "per_view factors each view on its own, Sattler et al. 2003) is chosen by the budget. With --max-error "
      "each representation gets the smallest rank whose relative RMS error meets it and the one with the "
      "fewest bytes of factors is kept (factors as large as the full BTF do not count as meeting it); with "
      "--max-bytes each gets the largest rank that fits and the most accurate is kept; --rank fixes the rank. "
      "Spectrum, error per rank, bytes, every representation tried and the reason go into error_report.json "
      "(btf_compression); each representation tried is one log line (rank, bytes, error, seconds).\n\n"
      "Choosing a representation (the default) or the clustered layout reads the full BTF once and holds it "
      "in memory, up to 2 GiB of float RGB (a paper-rig BTF at 128 x 128 texels, docs/FORMATS.md "
      "\"The full BTF\": the default choice takes about 14 minutes and 6 GB); above that the choice leaves the "
      "clustered layout out. One "
      "fixed representation of another layout streams the BTF from its view files in bands of about 64 MiB "
      "(a paper-rig BTF compresses in about 350 MiB). Matrices over 2048 columns a side (per_texel "
      "on the paper rig) are factored by a randomized SVD (--svd; svd in the report).");
  sub->add_option("--in", o->in, "material package holding a full BTF")->required()->check(CLI::ExistingDirectory);
  sub->add_option("--out", o->out, "material package folder to write")->required();
  AddCompressionOptions(sub, &o->compression);
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->callback([o] {
    pipelines::RunCompress(*o);
    spdlog::info("wrote {}", o->out.string());
  });
}

}  // namespace mesocap
