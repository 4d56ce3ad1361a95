// An OBJ mesh as a scene. Only the geometry subset is read: "v x y z" and
// "f" with triangles, quads or (convex) polygons, indices 1-based or negative
// (relative to the vertices so far), with optional /vt/vn parts. Every other
// statement (vt, vn, g, o, s, usemtl, mtllib, l, ...) is ignored.
#include <Eigen/Geometry>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "sim/tile_geometry.h"
#include "sim/tiled_scene.h"

namespace mesocap::sim {
namespace fs = std::filesystem;
namespace {

struct ObjMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;
};

std::vector<std::string_view> SplitWhitespace(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const std::size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

// Whole-token number parse: "1.5x" is an error, not 1.5.
template <class Number>
bool ParseNumber(std::string_view token, Number* value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return error == std::errc() && end == token.data() + token.size();
}

ObjMesh ReadObjMesh(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw FormatError(file, "", "not found or not a regular file");
  std::ifstream in(file);
  if (!in) throw FormatError(file, "", "cannot open the file");
  ObjMesh mesh;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const auto fail = [&](const std::string& problem) {
      throw FormatError(file, "line " + std::to_string(number), problem);
    };
    const std::vector<std::string_view> tokens = SplitWhitespace(line);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    if (tokens[0] == "v") {
      // "v x y z [w]" or "v x y z r g b": only x, y, z are used.
      Eigen::Vector3d v;
      if (tokens.size() < 4) fail("a vertex needs 3 coordinates");
      for (int k = 0; k < 3; ++k) {
        if (!ParseNumber(tokens[k + 1], &v[k]))
          fail("vertex coordinate '" + std::string(tokens[k + 1]) + "' is not a number");
      }
      if (!v.allFinite()) fail("vertex coordinate is not finite");
      mesh.vertices.push_back(v);
    } else if (tokens[0] == "f") {
      if (tokens.size() < 4) fail("a face needs at least 3 vertices");
      std::vector<int> face;
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const std::string_view vertex = tokens[k].substr(0, tokens[k].find('/'));
        long index = 0;
        if (!ParseNumber(vertex, &index))
          fail("face index '" + std::string(tokens[k]) + "' is not an integer");
        const long count = static_cast<long>(mesh.vertices.size());
        if (index < 0) index += count + 1;  // -1 is the last vertex so far
        if (index < 1 || index > count) {
          fail("face index " + std::string(vertex) + " does not name one of the " + std::to_string(count) +
               " vertices so far");
        }
        face.push_back(static_cast<int>(index - 1));
      }
      // A fan: exact for the triangles and convex polygons OBJ exporters write.
      for (std::size_t k = 1; k + 1 < face.size(); ++k)
        mesh.triangles.emplace_back(face[0], face[k], face[k + 1]);
    }
  }
  if (in.bad()) throw FormatError(file, "", "read error");
  if (mesh.triangles.empty()) throw FormatError(file, "f", "the mesh has no faces");
  return mesh;
}

}  // namespace

std::unique_ptr<MesostructureScene> LoadObjScene(const fs::path& obj, double scale) {
  if (!(scale > 0.0) || !std::isfinite(scale)) {
    throw Error(obj.string() + ": OBJ scale must be positive and finite, got " + std::to_string(scale));
  }
  const ObjMesh mesh = ReadObjMesh(obj);

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
  if (!extent.allFinite()) throw FormatError(obj, "v", "coordinates overflow after scaling");
  if (!(extent.x() > 0.0)) throw FormatError(obj, "v", "the mesh has no extent in x");
  // The x, y extent is one tile: a tile must be square.
  if (std::abs(extent.y() - extent.x()) > 0.01 * extent.x()) {
    throw FormatError(obj, "v",
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
  if (!any_area) throw FormatError(obj, "f", "every face has zero area");
  return MakeTiledScene(std::move(g));
}

}  // namespace mesocap::sim
