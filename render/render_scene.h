// A scene for the renderers: camera, point light,
// objects (the paper's shapes or an OBJ mesh) with a material or a plain
// diffuse albedo. JSON form in docs/FORMATS.md "Render scene"; the shipped
// scenes live in render/scenes/.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "render/render_material.h"
#include "render/render_mesh.h"

namespace mesocap::render {

struct SceneCamera {
  Eigen::Vector3d position{0, -200, 100};
  Eigen::Vector3d look_at{0, 0, 0};
  Eigen::Vector3d up{0, 0, 1};
  double fov_y_deg = 40.0;
};

// A point light of radiant intensity `intensity` (irradiance I / r^2 normal
// to the light); points in macroscale shadow are shaded with
// ambient * La (Sec. 4.2).
struct SceneLight {
  Eigen::Vector3d position{200, -200, 300};
  double intensity = 1e5;
  double ambient = 0.1;
};

struct SceneObject {
  std::string name;
  RenderMesh mesh;                           // world space, tangent frames computed
  int material = -1;                         // index into RenderScene::materials; -1: plain diffuse
  Eigen::Vector3f albedo{0.5f, 0.5f, 0.5f};  // plain objects only
};

struct RenderScene {
  std::filesystem::path file;
  SceneCamera camera;
  SceneLight light;
  double exposure = 1.0;  // image value = exposure * radiance
  std::vector<SceneObject> objects;
  std::vector<RenderMaterial> materials;

  // Centre and radius of a sphere around every object.
  std::pair<Eigen::Vector3d, double> Bounds() const;
};

// Turns a scene's material string into a material: a package path (relative
// to the scene's folder) or a built-in name such as "sim:brick".
using MaterialResolver = std::function<RenderMaterial(const std::string& spec, const std::filesystem::path& scene_dir)>;
// The resolver for package paths only (LoadRenderMaterial).
RenderMaterial ResolvePackageMaterial(const std::string& spec, const std::filesystem::path& scene_dir);

// Reads and validates a scene file and builds its meshes and materials.
// Throws FormatError naming the file and field for bad content, and passes on
// the resolver's errors for a missing or malformed material.
RenderScene ReadRenderScene(const std::filesystem::path& file, const MaterialResolver& resolver);

}  // namespace mesocap::render
