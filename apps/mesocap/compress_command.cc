// `mesocap compress --in MATERIAL --out MATERIAL2 [--rank K | --max-error E |
// --max-bytes B] [--layout auto|paper|per_texel|clustered] [--clusters N] [--color auto|rgb|ycbcr]`:
// factors the full BTF of any material package (a ground-truth one too) by
// SVD (Wang et al. 2005 Sec. 5) into a new package (pipelines/compress.h),
// in the representation that meets the budget in the fewest bytes.
#include <spdlog/spdlog.h>

#include "apps/mesocap/command.h"
#include "apps/mesocap/compression_options.h"
#include "apps/mesocap/help_text.h"
#include "pipelines/compress.h"

namespace mesocap {

void RegisterCompressCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::CompressOptions>();
  CLI::App* sub = app.add_subcommand("compress", HelpText("compress"));
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
