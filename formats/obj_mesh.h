// Wavefront OBJ meshes: the subset mesocap reads. "v x y z", "vt u v",
// "vn x y z" and "f" with triangles, quads or (convex) polygons, each corner
// "v", "v/vt", "v//vn" or "v/vt/vn", indices 1-based or negative (relative
// to the elements so far). Polygons are split into fans. Every other
// statement (g, o, s, usemtl, mtllib, l, ...) is ignored. Used by the
// simulated OBJ scenes (geometry only) and the renderers (with texture
// coordinates and normals).
#pragma once

#include <Eigen/Core>
#include <array>
#include <filesystem>
#include <vector>

namespace mesocap::formats {

struct ObjMesh {
  struct Corner {
    int position = -1;
    int texcoord = -1;  // -1: the face gives none
    int normal = -1;
  };
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector2d> texcoords;
  std::vector<Eigen::Vector3d> normals;
  std::vector<std::array<Corner, 3>> triangles;
};

// Throws FormatError naming the file and the line ("line 7") for a missing
// file, a non-number or a coordinate outside [-1e6, 1e6] (non-finite ones
// included), a short element, an index that names no element so far, and a
// mesh with no faces.
ObjMesh ReadObjMesh(const std::filesystem::path& file);

}  // namespace mesocap::formats
