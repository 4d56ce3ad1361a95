// One tile of mesostructure as a triangle soup, before it becomes a traceable
// scene: built by the procedural scenes and the OBJ / height-map loaders,
// consumed by MakeTiledScene (tiled_scene.h). Internal to sim/.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "sim/mesostructure_scene.h"

namespace mesocap::sim {

// Every member has an initializer so that builders can use designated
// initializers ({.name = ..., .tile_size_mm = ...}) under -Wextra.
struct TileGeometry {
  std::string name{};
  double tile_size_mm = 0.0;  // period P in x and y
  double d_max_mm = 0.0;      // slab depth: geometry lies in -d_max <= z <= 0

  std::vector<Eigen::Vector3d> vertices{};   // tile frame, mm
  std::vector<Eigen::Vector3i> triangles{};  // indices into vertices
  std::vector<int> triangle_part{};          // per triangle: index into parts

  // One reflectance per part (a block, a brick, a thread, the base).
  std::vector<Reflectance> parts{};
  // Amplitude of a smooth, tile-periodic modulation of the diffuse albedo
  // (0 = each part has exactly its albedo; 0.15 = +-15%).
  float albedo_variation = 0.0f;

  // Adds a part and returns its index.
  int AddPart(const Reflectance& reflectance);
  int AddVertex(const Eigen::Vector3d& p);
  void AddTriangle(int a, int b, int c, int part);
  // Two triangles a-b-c, a-c-d (a planar or nearly planar quad).
  void AddQuad(int a, int b, int c, int d, int part);
  // The square [0, P] x [0, P] at height z: the base the objects stand on.
  void AddBase(double z, int part);
};

// The albedo of `part` at tile point (x, y), with the smooth variation.
Reflectance ReflectanceAt(const TileGeometry& geometry, int part, double x, double y);

// Throws std::logic_error when the geometry breaks what the tiled tracer
// relies on: finite vertices, valid indices and parts, z in [-d_max, 0], and
// x, y within half a period outside the tile ([-P/2, 3P/2]) so that the tile
// and its 8 neighbours contain everything that reaches into a tile cell.
void CheckTileGeometry(const TileGeometry& geometry);

}  // namespace mesocap::sim
