// Mesostructure scenes for the simulated rig: one tile of geometry with known
// shape, repeated periodically in x and y, lying under the reference plane
// (docs/ARCHITECTURE.md "Conventions of the data": +z out of the sample, mesostructure in
// -d_max <= z <= 0). Ray tracing through Embree.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace mesocap::sim {

// Reflectance at a surface point: a diffuse lobe and a glossy lobe
// (normalized Blinn-Phong), both in linear RGB.
struct Reflectance {
  Eigen::Vector3f diffuse_albedo = Eigen::Vector3f::Constant(0.5f);
  float specular_albedo = 0.0f;  // 0 = purely diffuse
  float glossy_exponent = 20.0f;

  // BRDF value f_r(wi, wo) for unit normal n and unit wi (to light), wo (to
  // viewer): diffuse_albedo / pi + specular_albedo (e + 8) / (8 pi) (n.h)^e.
  // Zero when wi or wo is below the surface.
  Eigen::Vector3f Evaluate(const Eigen::Vector3d& n, const Eigen::Vector3d& wi, const Eigen::Vector3d& wo) const;
};

struct SurfaceHit {
  double distance = 0.0;   // along the (unit) ray direction, mm
  Eigen::Vector3d point;   // in the frame of the ray (not wrapped into the tile)
  Eigen::Vector3d normal;  // unit, facing against the ray
  Reflectance reflectance;
};

class MesostructureScene {
 public:
  virtual ~MesostructureScene() = default;

  const std::string& name() const { return name_; }
  // Period of the tiling in x and y (mm); the tile covers [0, P) x [0, P).
  double tile_size_mm() const { return tile_size_mm_; }
  // Depth of the slab: all geometry lies in -d_max <= z <= 0.
  double d_max_mm() const { return d_max_mm_; }

  // Offset for t_min of rays that leave a surface point (shadow rays,
  // bounces): 1e-4 (P + d_max), ~1000 times the single-precision rounding
  // inside the tracer (so the ray does not find its own surface down to
  // ~0.1 degree above it) and far below any feature size.
  double surface_epsilon_mm() const { return 1e-4 * (tile_size_mm_ + d_max_mm_); }

  // First hit of the ray origin + t * dir (dir unit), t in [t_min, t_max],
  // with the infinitely tiled mesostructure. The interval is closed so that
  // a ray starting on the reference plane with t_min = 0 finds a top at
  // z = 0 (distance 0); a ray leaving a surface passes surface_epsilon_mm().
  // Rays that leave the slab without a hit (through-holes, or upwards)
  // return nullopt, and so do rays that would cross more than
  // kMaxCellsPerRay tiles inside the slab (cell_walk.h: within a few
  // hundredths of a degree of horizontal). Which face a ray meets is decided
  // in single precision (Embree), so offsets below ~1e-7 (P + d_max), about
  // a nanometre, are not resolved; the distance, point and normal on that
  // face are then exact to ~1e-12 relative (refined in double precision).
  virtual std::optional<SurfaceHit> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                                              double t_max) const = 0;
  // Whether Intersect would find a hit in [t_min, t_max]: for shadow rays.
  virtual bool Occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                        double t_max) const = 0;

 protected:
  MesostructureScene(std::string name, double tile_size_mm, double d_max_mm)
      : name_(std::move(name)), tile_size_mm_(tile_size_mm), d_max_mm_(d_max_mm) {}

 private:
  std::string name_;
  double tile_size_mm_;
  double d_max_mm_;
};

// Built-in scenes (P = tile size, all in mm; each tile is a 3-6 tile wide
// patch of a 20-40 mm sample). Albedos are per object with a smooth +-10-15%
// variation, except in flat and box, whose albedos are constant per part.
//   flat    P 5, d_max 1: the plane z = 0, Lambertian albedo 0.5. MDF D = 0
//           and BTF = 0.5 / pi everywhere (d_max is nominal: nothing below 0).
//   box     P 5, d_max 1: a 2 x 2 x 1 box [1.5, 3.5]^2 x [-1, 0] on a base at
//           z = -1. The analytic MDF case: D = 1 / cos(theta) on the base
//           where the ray passes beside the box, 0 on its top.
//   blocks  P 9, d_max 2: 3 x 3 blocks (2.2 mm wide, 0.4-2 mm tall) on a
//           base: a height field with steep depth steps and cast shadows.
//   brick   P 8, d_max 0.5: running-bond bricks 3.6 x 1.6 mm, mortar joints
//           0.4 mm wide recessed 0.5 mm; bricks cross the tile border.
//   weave   P 4, d_max 3: plain weave of round threads (r 0.6 mm, pitch
//           2 mm) over a dark backing at z = -3: not a height field (free
//           space under threads, 0.1 mm gaps at crossings).
//   pipes   P 6, d_max 2.6: two pipes along x (r 1 and 0.8) held 0.6 mm
//           above the base: undercuts seen only from oblique directions.
//   grass   P 4, d_max 2: 24 thin bent blades (zero-thickness triangles,
//           0.1-0.16 mm wide) on soil: thin features and fine shadows.
//   sponge  P 4, d_max 1.2: a two-layer lattice of bars with no base: rays
//           through the open squares (e.g. the vertical at (2, 1)) leave
//           the slab with no hit.
std::vector<std::string> BuiltinSceneNames();
std::unique_ptr<MesostructureScene> MakeBuiltinScene(const std::string& name);
// User geometry: an OBJ mesh whose x, y span one tile (in mm after `scale`),
// shifted so its top is at z = 0; or a height map image (0 = deepest,
// 1 = top) of physical tile size and depth. Both are grey (albedo 0.5).
// Throw FormatError naming the file (and the OBJ line) for bad content:
// OBJ without faces, non-finite vertices, bad indices, x and y extents
// differing by more than 1%; height values outside [0, 1], more than
// 1024 x 1024 pixels. Details in obj_scene.cc and height_map_scene.cc.
std::unique_ptr<MesostructureScene> LoadObjScene(const std::filesystem::path& obj, double scale);
std::unique_ptr<MesostructureScene> LoadHeightMapScene(const std::filesystem::path& image, double tile_size_mm,
                                                       double depth_mm);

// Where a scene comes from, as a user names it: a built-in scene name, an
// OBJ file (.obj, with its scale) or a height map image (.png, .exr, .tif,
// .tiff, with its tile size and depth), told by the extension.
struct SceneSource {
  std::string scene = "weave";
  double obj_scale = 1.0;     // OBJ units to mm
  double tile_size_mm = 4.0;  // height map: side of one tile
  double depth_mm = 1.0;      // height map: depth of value 0 below value 1
};
std::unique_ptr<MesostructureScene> LoadScene(const SceneSource& source);

}  // namespace mesocap::sim
