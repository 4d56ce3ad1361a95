// What `mesocap render`, `compare` and `view` share: reading a render scene
// with its materials (package paths, or built-in "sim:NAME" materials made
// from ground truth and cached), and the --size / --passes options.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>

#include "render/peeling_renderer.h"
#include "render/render_scene.h"

namespace mesocap {

struct RenderSceneOptions {
  std::filesystem::path scene;
  std::string size = "800x600";
  std::string passes = "auto";
  int shadow_map_size = 1024;

  // PeelingOptions of the flags (throws Error naming the bad flag).
  render::PeelingOptions Peeling() const;
};

void AddRenderSceneOptions(CLI::App* command, RenderSceneOptions* options);

// A "sim:NAME" material: the ground-truth package of the built-in scene
// (render::SimMaterialGroundTruthOptions), cached under
// $MESOCAP_CACHE_DIR (default $XDG_CACHE_HOME/mesocap or ~/.cache/mesocap),
// with its true tile geometry for the CPU reference. Other strings are
// package paths relative to the scene's folder.
render::RenderMaterial ResolveRenderMaterial(const std::string& spec, const std::filesystem::path& scene_dir);

}  // namespace mesocap
