// `mesocap groundtruth --scene S --rig R --out MATERIAL`: the exact material
// package of a simulated scene (MDF, BTF, ambient term) and the rig's true
// calibration, computed directly in texture space (pipelines/ground_truth.h).
#include <spdlog/spdlog.h>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "apps/mesocap/scene_option.h"
#include "formats/material_manifest.h"
#include "pipelines/ground_truth.h"

namespace mesocap {

void RegisterGroundTruthCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::GroundTruthOptions>();
  CLI::App* sub = app.add_subcommand("groundtruth", HelpText("groundtruth"));
  AddSceneOptions(sub, &o->scene);
  sub->add_option("--rig", o->rig, "shipped rig (tiny, small, paper) or a rig description file")->capture_default_str();
  sub->add_option("--out", o->out, "material package folder to write")->required();
  sub->add_option("--texture-size", o->texture_size, "texels per side of the texture grid")
      ->check(InRange(1, 4096))
      ->capture_default_str();
  sub->add_option("--texel-samples-per-side", o->texel_samples_per_side,
                  "the BTF and ambient term of a texel are the mean of n x n samples of its area (1: its centre)")
      ->check(InRange(1, formats::kMaxTexelSamplesPerSide))
      ->capture_default_str();
  sub->add_option("--views", o->views,
                  "view directions: \"rig\" (the rig's own) or a sampling set name "
                  "(paper12x8, ubo2003, ubo2014, grid<A>x<P>, ...)")
      ->capture_default_str();
  sub->add_option("--lights", o->lights, "light directions, as --views")->capture_default_str();
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->callback([o] {
    pipelines::RunGroundTruth(*o);
    spdlog::info("wrote {}", o->out.string());
  });
}

}  // namespace mesocap
