#include "apps/mesocap/scene_option.h"

#include <string>

#include "apps/mesocap/command.h"

namespace mesocap {

void AddSceneOptions(CLI::App* command, sim::SceneSource* source) {
  std::string names;
  for (const auto& n : sim::BuiltinSceneNames()) names += (names.empty() ? "" : ", ") + n;
  command->add_option("--scene", source->scene, "built-in scene (" + names + "), an OBJ file or a height map image")
      ->capture_default_str();
  command->add_option("--scale", source->obj_scale, "OBJ units to mm")
      ->check(InRange(1e-6, 1e6))
      ->capture_default_str();
  command->add_option("--tile-size-mm", source->tile_size_mm, "height map: side of one tile in mm")
      ->check(InRange(1e-3, 1e4))
      ->capture_default_str();
  command->add_option("--depth-mm", source->depth_mm, "height map: depth of value 0 below value 1 in mm")
      ->check(InRange(1e-3, 1e3))
      ->capture_default_str();
}

}  // namespace mesocap
