// `mesocap groundtruth --scene S --rig R --out MATERIAL`: the exact material
// package of a simulated scene (MDF, BTF, ambient term) and the rig's true
// calibration, computed directly in texture space.
#include <filesystem>
#include <spdlog/spdlog.h>

#include "apps/mesocap/command.h"
#include "apps/mesocap/scene_option.h"
#include "calibration/nominal_geometry.h"
#include "core/error.h"
#include "sim/ground_truth.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"

namespace mesocap {
namespace {

struct GroundTruthCommandOptions {
  SceneOption scene;
  std::string rig = "tiny";
  std::filesystem::path out;
  int texture_size = 64;
  std::string views = "rig";
  std::string lights = "rig";
  bool replace = false;
};

core::SamplingSet DirectionSet(const std::string& name, const core::SamplingSet& rig_set) {
  return name == "rig" ? rig_set : core::SamplingSet::Named(name);
}

void RunGroundTruth(const GroundTruthCommandOptions& o) {
  const auto scene = o.scene.Load();
  const formats::RigDescription rig = sim::LoadRig(o.rig);
  sim::GroundTruthOptions gt;
  gt.texture_width = gt.texture_height = o.texture_size;
  gt.sample_size_mm = rig.sample_size_mm;
  gt.views = DirectionSet(o.views, calibration::ViewDirections(rig));
  gt.lights = DirectionSet(o.lights, calibration::LightDirections(rig));
  if (const auto problem = gt.Check(); !problem.empty()) throw core::Error("groundtruth: " + problem);
  const formats::Calibration calibration = sim::TrueCalibration(rig);
  spdlog::info("ground truth of scene {} on rig {}: {}x{} texels, {} views x {} lights", scene->name(), rig.name,
               gt.texture_width, gt.texture_height, gt.views.size(), gt.lights.size());
  sim::WriteGroundTruthPackage(*scene, gt, &calibration,
                               "groundtruth scene=" + scene->name() + " rig=" + rig.name, o.out, o.replace);
  spdlog::info("wrote {}", o.out.string());
}

}  // namespace

void RegisterGroundTruthCommand(CLI::App& app) {
  auto o = std::make_shared<GroundTruthCommandOptions>();
  CLI::App* sub = app.add_subcommand(
      "groundtruth", "Write the exact material package (MDF, BTF, ambient term, true calibration) of a simulated scene");
  AddSceneOptions(sub, &o->scene);
  sub->add_option("--rig", o->rig, "shipped rig (tiny, small, paper) or a rig description file")
      ->capture_default_str();
  sub->add_option("--out", o->out, "material package folder to write")->required();
  sub->add_option("--texture-size", o->texture_size, "texels per side of the texture grid")
      ->check(CLI::Range(1, 4096))
      ->capture_default_str();
  sub->add_option("--views", o->views, "view directions: \"rig\" (the rig's own) or a sampling set name "
                                       "(paper12x8, ubo2003, ubo2014, grid<A>x<P>, ...)")
      ->capture_default_str();
  sub->add_option("--lights", o->lights, "light directions, as --views")->capture_default_str();
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->callback([o] { RunGroundTruth(*o); });
}

}  // namespace mesocap
