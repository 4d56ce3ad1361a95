// `mesocap process btf --session S --calibration C --out MATERIAL
// [--rank K | --max-error E | --max-bytes B] [--layout L] [--color C]`: the BTF of a capture session (Wang et al. 2005
// Sec. 3.1 and 5), its SVD factors and ambient term (Sec. 4.2) in a new
// material package (pipelines/process_btf.h). Each camera's gain (signal per
// radiance second) is its calibration's radiometry unless --gain gives one
// for all.
#include <spdlog/spdlog.h>

#include "apps/mesocap/command.h"
#include "apps/mesocap/compression_options.h"
#include "apps/mesocap/help_text.h"
#include "formats/calibration.h"
#include "pipelines/process_btf.h"

namespace mesocap {

void RegisterProcessBtfCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::ProcessBtfOptions>();
  CLI::App* process = GroupCommand(app, "process", "Turn a capture session into a material");
  CLI::App* sub = process->add_subcommand("btf", HelpText("process_btf"));
  sub->add_option("--session", o->session, "capture session folder")->required()->check(CLI::ExistingDirectory);
  sub->add_option("--calibration", o->calibration, "calibration file (default: the one the session names)")
      ->check(CLI::ExistingFile);
  sub->add_option("--out", o->out, "material package folder to write")->required();
  sub->add_option("--texture-size", o->texture_size, "texels per side")->check(InRange(1, 4096))->capture_default_str();
  sub->add_option("--mdf", o->mdf,
                  "material package of the same session's MDF (mesocap process mdf, same --texture-size): the new "
                  "package carries it, so that it renders")
      ->check(CLI::ExistingDirectory);
  AddCompressionOptions(sub, &o->compression);
  sub->add_option("--gain", o->gain,
                  "camera signal (fraction of full scale) per radiance second, for every camera, overriding "
                  "the calibration's radiometry (default: each camera's from the calibration)")
      ->check(InRange(formats::kMinCameraGain, formats::kMaxCameraGain));
  sub->add_flag("--full", o->full, "also store the full (uncompressed) BTF");
  sub->add_flag("--resample", o->resample,
                "resample captures whose directions are off the session's sets (each texel with its own view and "
                "light directions) instead of requiring them within 1 degree");
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->add_option("--allow-incomplete", o->allow_incomplete,
                  "plan steps the session may lack, left out (step ids or patterns such as 'btf-t3_*'; '*': any)")
      ->delimiter(',');
  sub->callback([o] {
    pipelines::RunProcessBtf(*o);
    spdlog::info("wrote {}", o->out.string());
  });
}

}  // namespace mesocap
