// A test material for the renderers that needs no BTF compression: the true
// MDF and tile geometry of a built-in scene with a rank-1 Lambertian BTF made
// by hand (T = 0.5 / pi for every direction pair, so La = 0.5). Silhouettes
// and shadows depend on the MDF only.
#pragma once

#include <numbers>
#include <string>

#include "render/render_material.h"
#include "render/sim_material.h"
#include "sim/builtin_scenes.h"
#include "sim/mesostructure_scene.h"

namespace mesocap::render {

inline RenderMaterial LambertianSimMaterial(const std::string& scene_name, int texture_size) {
  sim::GroundTruthOptions options = SimMaterialGroundTruthOptions(scene_name);
  options.texels.width = options.texels.height = texture_size;
  const auto scene = sim::MakeBuiltinScene(scene_name);
  RenderMaterial m;
  m.name = "sim:" + scene_name;
  m.sample_size_mm = options.texels.sample_size_mm;
  m.d_max_mm = scene->d_max_mm();
  m.mdf = sim::ComputeTrueMdf(*scene, options);
  const int w = texture_size, h = texture_size;
  m.btf.width = w;
  m.btf.height = h;
  m.btf.views = options.views;
  m.btf.lights = options.lights;
  m.btf.rows = {core::Image(w, h * options.lights.size(), 3, 0.5f / std::numbers::pi_v<float>)};
  m.btf.columns = core::Image(options.views.size(), 1, 3, 1.0f);
  m.ambient.width = w;
  m.ambient.height = h;
  m.ambient.views = options.views;
  m.ambient.values = core::Image(w, h * options.views.size(), 3, 0.5f);
  m.geometry = sim::BuiltinTileGeometry(scene_name);
  return m;
}

}  // namespace mesocap::render
