// An OBJ mesh as a scene (formats/obj_mesh.h reads it): only the positions and
// faces are used.
#include <Eigen/Geometry>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"
#include "formats/obj_mesh.h"
#include "sim/tile_geometry.h"
#include "sim/tiled_scene.h"

namespace mesocap::sim {
namespace fs = std::filesystem;

std::unique_ptr<MesostructureScene> LoadObjScene(const fs::path& obj, double scale) {
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    throw core::Error(obj.string() + ": OBJ scale must be positive and finite, got " + std::to_string(scale));
  }
  const formats::ObjMesh obj_mesh = formats::ReadObjMesh(obj);
  struct {
    std::vector<Eigen::Vector3d> vertices;
    std::vector<Eigen::Vector3i> triangles;
  } mesh{obj_mesh.positions, {}};
  for (const auto& t : obj_mesh.triangles) mesh.triangles.emplace_back(t[0].position, t[1].position, t[2].position);

  // Only vertices used by faces define the tile; stray points are dropped.
  TileGeometry g;
  g.name = obj.filename().string();
  std::vector<int> used(mesh.vertices.size(), -1);
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      if (used[t[k]] < 0) used[t[k]] = g.AddVertex(scale * mesh.vertices[t[k]]);
    }
  }
  Eigen::Vector3d lo = g.vertices[0], hi = g.vertices[0];
  for (const Eigen::Vector3d& v : g.vertices) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const Eigen::Vector3d extent = hi - lo;
  if (!extent.allFinite()) throw core::FormatError(obj, "v", "coordinates overflow after scaling");
  if (!(extent.x() > 0.0)) throw core::FormatError(obj, "v", "the mesh has no extent in x");
  // The x, y extent is one tile: a tile must be square.
  if (std::abs(extent.y() - extent.x()) > 0.01 * extent.x()) {
    throw core::FormatError(obj, "v",
                            "x and y extents must be equal within 1% (one square tile), got " +
                                std::to_string(extent.x()) + " and " + std::to_string(extent.y()) + " mm");
  }
  g.tile_size_mm = extent.x();
  g.d_max_mm = extent.z();
  const Eigen::Vector3d shift(-lo.x(), -lo.y(), -hi.z());  // tile at the origin, top at z = 0
  for (Eigen::Vector3d& v : g.vertices) v += shift;
  const int part = g.AddPart(Reflectance{});  // user geometry carries no material: grey 0.5
  bool any_area = false;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    g.AddTriangle(used[t[0]], used[t[1]], used[t[2]], part);
    const Eigen::Vector3d& a = g.vertices[used[t[0]]];
    any_area |= (g.vertices[used[t[1]]] - a).cross(g.vertices[used[t[2]]] - a).squaredNorm() > 0.0;
  }
  if (!any_area) throw core::FormatError(obj, "f", "every face has zero area");
  return MakeTiledScene(std::move(g));
}

}  // namespace mesocap::sim
