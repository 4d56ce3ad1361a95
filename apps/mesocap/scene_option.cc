#include "apps/mesocap/scene_option.h"

#include <filesystem>

namespace mesocap {

std::unique_ptr<sim::MesostructureScene> SceneOption::Load() const {
  const std::string ext = std::filesystem::path(scene).extension().string();
  if (ext == ".obj" || ext == ".OBJ") return sim::LoadObjScene(scene, obj_scale);
  if (ext == ".png" || ext == ".exr" || ext == ".tif" || ext == ".tiff") {
    return sim::LoadHeightMapScene(scene, tile_size_mm, depth_mm);
  }
  return sim::MakeBuiltinScene(scene);
}

void AddSceneOptions(CLI::App* command, SceneOption* option) {
  std::string names;
  for (const auto& n : sim::BuiltinSceneNames()) names += (names.empty() ? "" : ", ") + n;
  command->add_option("--scene", option->scene, "built-in scene (" + names + "), an OBJ file or a height map image")
      ->capture_default_str();
  command->add_option("--scale", option->obj_scale, "OBJ units to mm")->capture_default_str();
  command->add_option("--tile-size-mm", option->tile_size_mm, "height map: side of one tile in mm")
      ->capture_default_str();
  command->add_option("--depth-mm", option->depth_mm, "height map: depth of value 0 below value 1 in mm")
      ->capture_default_str();
}

}  // namespace mesocap
