#include "sim/tile_geometry.h"
#include "core/angles.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace mesocap::sim {

int TileGeometry::AddPart(const Reflectance& reflectance) {
  parts.push_back(reflectance);
  return static_cast<int>(parts.size()) - 1;
}

int TileGeometry::AddVertex(const Eigen::Vector3d& p) {
  vertices.push_back(p);
  return static_cast<int>(vertices.size()) - 1;
}

void TileGeometry::AddTriangle(int a, int b, int c, int part) {
  triangles.emplace_back(a, b, c);
  triangle_part.push_back(part);
}

void TileGeometry::AddQuad(int a, int b, int c, int d, int part) {
  AddTriangle(a, b, c, part);
  AddTriangle(a, c, d, part);
}

void TileGeometry::AddBase(double z, int part) {
  const double p = tile_size_mm;
  AddQuad(AddVertex({0, 0, z}), AddVertex({p, 0, z}), AddVertex({p, p, z}), AddVertex({0, p, z}), part);
}

Reflectance ReflectanceAt(const TileGeometry& geometry, int part, double x, double y) {
  Reflectance r = geometry.parts[part];
  if (geometry.albedo_variation == 0.0f) return r;
  // Two low-frequency waves, periodic in the tile so the pattern is seamless.
  const double u = x / geometry.tile_size_mm;
  const double v = y / geometry.tile_size_mm;
  const double wave = 0.5 * (std::sin(core::kTwoPi * u + 0.3) + std::cos(core::kTwoPi * (u + 2.0 * v)));
  const float scale = 1.0f + geometry.albedo_variation * static_cast<float>(wave);
  r.diffuse_albedo = (r.diffuse_albedo * scale).cwiseMax(0.0f).cwiseMin(1.0f);
  return r;
}

void CheckTileGeometry(const TileGeometry& g) {
  const auto fail = [&](const std::string& what) { throw std::logic_error("tile geometry '" + g.name + "': " + what); };
  const double p = g.tile_size_mm;
  if (!(p > 0.0) || !std::isfinite(p)) fail("tile size must be positive");
  if (!(g.d_max_mm >= 0.0) || !std::isfinite(g.d_max_mm)) fail("d_max must be >= 0");
  if (g.triangles.empty()) fail("no triangles");
  if (g.triangle_part.size() != g.triangles.size()) fail("one part per triangle expected");
  // Rounding of the builders' arithmetic, not a licence to leave the slab.
  const double tol = 1e-9 * (p + g.d_max_mm);
  for (const Eigen::Vector3d& v : g.vertices) {
    if (!v.allFinite()) fail("vertex is not finite");
    if (v.z() > tol || v.z() < -g.d_max_mm - tol) fail("vertex outside the slab -d_max <= z <= 0");
    if (v.x() < -0.5 * p || v.x() > 1.5 * p || v.y() < -0.5 * p || v.y() > 1.5 * p) {
      fail("vertex more than half a period outside the tile: objects must be smaller than one period");
    }
  }
  const int n = static_cast<int>(g.vertices.size());
  for (std::size_t i = 0; i < g.triangles.size(); ++i) {
    const Eigen::Vector3i& t = g.triangles[i];
    if (t.minCoeff() < 0 || t.maxCoeff() >= n) fail("triangle index out of range");
    if (g.triangle_part[i] < 0 || g.triangle_part[i] >= static_cast<int>(g.parts.size())) {
      fail("triangle part out of range");
    }
  }
}

}  // namespace mesocap::sim
