#include "sim/mesostructure_scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace mesocap::sim {

Eigen::Vector3f Reflectance::Evaluate(const Eigen::Vector3d& n, const Eigen::Vector3d& wi,
                                      const Eigen::Vector3d& wo) const {
  // Light or viewer below the surface: the surface is not lit or not seen.
  if (n.dot(wi) <= 0.0 || n.dot(wo) <= 0.0) return Eigen::Vector3f::Zero();
  Eigen::Vector3f f = diffuse_albedo / std::numbers::pi_v<float>;
  if (specular_albedo > 0.0f) {
    const double cos_h = std::max(0.0, n.dot((wi + wo).normalized()));
    // (e + 8) / (8 pi) keeps the lobe's albedo near specular_albedo for every e.
    const double lobe = (glossy_exponent + 8.0) / (8.0 * std::numbers::pi) * std::pow(cos_h, glossy_exponent);
    f.array() += static_cast<float>(specular_albedo * lobe);
  }
  return f;
}

std::unique_ptr<MesostructureScene> LoadScene(const SceneSource& source) {
  const std::string ext = std::filesystem::path(source.scene).extension().string();
  if (ext == ".obj" || ext == ".OBJ") return LoadObjScene(source.scene, source.obj_scale);
  if (ext == ".png" || ext == ".exr" || ext == ".tif" || ext == ".tiff") {
    return LoadHeightMapScene(source.scene, source.tile_size_mm, source.depth_mm);
  }
  return MakeBuiltinScene(source.scene);
}

}  // namespace mesocap::sim
