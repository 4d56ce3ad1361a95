// The --scene option shared by the commands that simulate: a built-in scene
// name, an OBJ mesh (with --scale) or a height map image (with --tile-size-mm
// and --depth-mm), bound to a sim::SceneSource.
#pragma once

#include <CLI/CLI.hpp>

#include "sim/mesostructure_scene.h"

namespace mesocap {

void AddSceneOptions(CLI::App* command, sim::SceneSource* source);

}  // namespace mesocap
