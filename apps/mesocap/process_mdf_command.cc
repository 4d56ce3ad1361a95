// `mesocap process mdf --session S --calibration C --out MATERIAL`: the 4D
// MDF of a capture session's laser scans (MDF paper Sec. 3.2), written in
// float and 8-bit form (Sec. 5) into a new material package
// (pipelines/process_mdf.h).
#include <spdlog/spdlog.h>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "pipelines/process_mdf.h"

namespace mesocap {

void RegisterProcessMdfCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::ProcessMdfOptions>();
  CLI::App* group = GroupCommand(app, "process", "Process a capture session into material package parts");
  CLI::App* sub = group->add_subcommand("mdf", HelpText("process_mdf"));
  sub->add_option("--session", o->session, "capture session folder")->required();
  sub->add_option("--calibration", o->calibration, "rig calibration file (default: the one the session names)");
  sub->add_option("--out", o->out, "material package folder to write")->required();
  sub->add_option("--texture-size", o->processing.texture_size, "texels per side")
      ->check(InRange(1, 4096))
      ->capture_default_str();
  sub->add_option("--locations", o->processing.locations, "laser locations to use (indices; default all)")
      ->check(InRange(0, 4095));
  sub->add_option("--threshold", o->processing.space_time.threshold,
                  "space-time peak threshold (fraction of full scale) below which a pixel is unknown")
      ->check(InRange(1e-6, 0.999999))
      ->capture_default_str();
  sub->add_option("--d-max-mm", o->d_max_mm, "slab depth of the package (default: deepest measured point)")
      ->check(InRange(1e-6, 1e4));
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->add_option("--allow-incomplete", o->allow_incomplete,
                  "plan steps the session may lack, left out (step ids or patterns such as 'laser-sweep-t3_*'; "
                  "'*': any)")
      ->delimiter(',');
  sub->callback([o] {
    const pipelines::ProcessMdfReport r = pipelines::RunProcessMdf(*o);
    spdlog::info("wrote {}: {} sweeps, {}x{} texels x {} views", o->out.string(), r.sweeps, r.texels_per_side,
                 r.texels_per_side, r.views);
    spdlog::info(
        "{} laser planes from their plates: height uncertainty at the sample centre at most {:.4f} mm "
        "(one sigma; -v for each plane)",
        r.laser_planes, r.worst_plane_height_sigma_mm);
  });
}

}  // namespace mesocap
