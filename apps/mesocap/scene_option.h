// The --scene option shared by the commands that simulate: a built-in scene
// name, an OBJ mesh (with --scale) or a height map image (with --tile-size-mm
// and --depth-mm).
#pragma once

#include <CLI/CLI.hpp>
#include <memory>
#include <string>

#include "sim/mesostructure_scene.h"

namespace mesocap {

struct SceneOption {
  std::string scene = "weave";
  double obj_scale = 1.0;
  double tile_size_mm = 4.0;
  double depth_mm = 1.0;

  std::unique_ptr<sim::MesostructureScene> Load() const;
};

void AddSceneOptions(CLI::App* command, SceneOption* option);

}  // namespace mesocap
