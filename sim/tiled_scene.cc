// Method. The tile's triangles go into one Embree scene together with their
// copies shifted by the 8 neighbouring periods (only copies that reach into
// the tile cell are kept). A ray is walked cell by cell (CellWalk); in cell
// (i, j) it is moved into the cell's own frame and Embree is asked only for
// the parameter interval where the ray is inside that cell. The first cell
// with a hit holds the first hit of the infinite tiling.
//
// Precision. Embree works in single precision, so
//  - each query is done from the point where the ray enters the cell, in
//    cell coordinates (all numbers are O(P)), never from a far-away origin;
//  - a cell's interval is widened by kCellMargin on both sides, so a hit
//    lying exactly on a cell border (a wall on the border, a ray along it)
//    is found by at least one of the two cells despite rounding; hits in the
//    margin are real hits because the copies cover the margin too;
//  - the distance, point and normal are recomputed in double precision from
//    the hit triangle (ray-plane intersection), so they are exact to ~1e-12
//    relative, not ~1e-7.
// Near-horizontal rays cross many cells; CellWalk computes each border from
// the cell index (no drift) and stops after kMaxCellsPerRay cells.
#include "sim/tiled_scene.h"

#include <embree3/rtcore.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "core/error.h"
#include "sim/cell_walk.h"
#include "sim/embree_handles.h"

namespace mesocap::sim {
namespace {

// Widening of each cell's query interval, relative to P + d_max: 1e-4 is
// ~1000 times the single-precision rounding of coordinates of size P + d_max.
constexpr double kCellMargin = 1e-4;

// A ray segment inside one cell, in the cell's frame: the points
// origin + s dir for s in [0, length] are the ray's points t = t_offset + s.
struct CellRay {
  Eigen::Vector3d origin;
  double t_offset = 0.0;
  double length = 0.0;
};

class TiledScene final : public MesostructureScene {
 public:
  explicit TiledScene(TileGeometry geometry);

  std::optional<SurfaceHit> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                                      double t_max) const override;
  bool Occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double t_max) const override;

 private:
  void BuildEmbreeScene();
  // Calls visit(cell_ray) for each cell the ray crosses until visit returns true.
  template <class Visit>
  bool Walk(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double t_max, Visit&& visit) const;
  RTCRay EmbreeRay(const CellRay& cell, const Eigen::Vector3d& dir) const;

  TileGeometry geometry_;
  double margin_ = 0.0;
  // Per Embree primitive: the tile triangle it copies and the copy's shift in periods.
  std::vector<std::uint32_t> prim_triangle_;
  std::vector<std::array<std::int8_t, 2>> prim_shift_;
  EmbreeDevice device_;
  EmbreeScene scene_;
};

TiledScene::TiledScene(TileGeometry geometry)
    : MesostructureScene(geometry.name, geometry.tile_size_mm, geometry.d_max_mm),
      geometry_(std::move(geometry)),
      margin_(kCellMargin * (tile_size_mm() + d_max_mm())) {
  BuildEmbreeScene();
}

void TiledScene::BuildEmbreeScene() {
  const TileGeometry& g = geometry_;
  const double p = g.tile_size_mm;
  // A copy is kept where it reaches within the query margin of the cell
  // (with headroom for the rounding of these bounds).
  const double reach = 4.0 * margin_;
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::int64_t> copy_of(9 * g.vertices.size(), -1);  // (copy, vertex) -> index
  for (std::int8_t sy = -1; sy <= 1; ++sy) {
    for (std::int8_t sx = -1; sx <= 1; ++sx) {
      const Eigen::Vector3d shift(sx * p, sy * p, 0.0);
      const std::size_t copy = static_cast<std::size_t>((sy + 1) * 3 + (sx + 1));
      for (std::size_t t = 0; t < g.triangles.size(); ++t) {
        const Eigen::Vector3i& tri = g.triangles[t];
        const Eigen::Vector3d& a = g.vertices[tri[0]];
        const Eigen::Vector3d& b = g.vertices[tri[1]];
        const Eigen::Vector3d& c = g.vertices[tri[2]];
        if ((b - a).cross(c - a).squaredNorm() == 0.0) continue;  // no area: never hit
        const Eigen::Vector3d lo = a.cwiseMin(b).cwiseMin(c) + shift;
        const Eigen::Vector3d hi = a.cwiseMax(b).cwiseMax(c) + shift;
        if (hi.x() < -reach || lo.x() > p + reach || hi.y() < -reach || lo.y() > p + reach) continue;
        std::array<std::uint32_t, 3> indices{};
        for (int k = 0; k < 3; ++k) {
          std::int64_t& index = copy_of[copy * g.vertices.size() + tri[k]];
          if (index < 0) {
            index = static_cast<std::int64_t>(vertices.size());
            vertices.push_back(g.vertices[tri[k]] + shift);
          }
          indices[k] = static_cast<std::uint32_t>(index);
        }
        triangles.push_back(indices);
        prim_triangle_.push_back(static_cast<std::uint32_t>(t));
        prim_shift_.push_back({sx, sy});
      }
    }
  }
  if (triangles.empty()) throw core::Error("scene '" + g.name + "': every triangle has zero area");

  device_.reset(rtcNewDevice(nullptr));
  if (!device_) {
    throw core::Error("Embree: cannot create a device (error " + std::to_string(rtcGetDeviceError(nullptr)) + ")");
  }
  scene_.reset(rtcNewScene(device_.get()));
  // ROBUST keeps the triangle test watertight along shared edges (the base's
  // diagonal, the seams between copies).
  rtcSetSceneFlags(scene_.get(), RTC_SCENE_FLAG_ROBUST);
  rtcSetSceneBuildQuality(scene_.get(), RTC_BUILD_QUALITY_HIGH);
  RTCGeometry mesh = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vertex_buffer = static_cast<float*>(
      rtcSetNewGeometryBuffer(mesh, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.size()));
  auto* index_buffer = static_cast<std::uint32_t*>(rtcSetNewGeometryBuffer(
      mesh, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(std::uint32_t), triangles.size()));
  if (vertex_buffer == nullptr || index_buffer == nullptr) {
    rtcReleaseGeometry(mesh);
    throw core::Error("Embree: cannot allocate the buffers of scene '" + g.name + "'");
  }
  for (std::size_t v = 0; v < vertices.size(); ++v) {
    for (int k = 0; k < 3; ++k) vertex_buffer[3 * v + k] = static_cast<float>(vertices[v][k]);
  }
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    std::copy(triangles[t].begin(), triangles[t].end(), index_buffer + 3 * t);
  }
  rtcCommitGeometry(mesh);
  rtcAttachGeometry(scene_.get(), mesh);
  rtcReleaseGeometry(mesh);
  rtcCommitScene(scene_.get());
  if (const RTCError error = rtcGetDeviceError(device_.get()); error != RTC_ERROR_NONE) {
    throw core::Error("Embree: cannot build scene '" + g.name + "' (error " + std::to_string(error) + ")");
  }
}

template <class Visit>
bool TiledScene::Walk(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double t_max,
                      Visit&& visit) const {
  const double p = tile_size_mm();
  CellWalk walk(origin, dir, t_min, t_max, p, d_max_mm());
  CellSpan span;
  while (walk.Next(&span)) {
    // The walk keeps spans inside [t_min, t_max]; the margin must too.
    CellRay cell;
    cell.t_offset = std::max(span.t_begin - margin_, t_min);
    const double t_end = std::min(span.t_end + margin_, t_max);
    cell.length = t_end - cell.t_offset;
    const Eigen::Vector3d corner(static_cast<double>(span.i) * p, static_cast<double>(span.j) * p, 0.0);
    cell.origin = origin + cell.t_offset * dir - corner;
    if (visit(cell)) return true;
  }
  return false;
}

RTCRay TiledScene::EmbreeRay(const CellRay& cell, const Eigen::Vector3d& dir) const {
  RTCRay ray{};
  ray.org_x = static_cast<float>(cell.origin.x());
  ray.org_y = static_cast<float>(cell.origin.y());
  ray.org_z = static_cast<float>(cell.origin.z());
  ray.dir_x = static_cast<float>(dir.x());
  ray.dir_y = static_cast<float>(dir.y());
  ray.dir_z = static_cast<float>(dir.z());
  ray.tnear = 0.0f;
  ray.tfar = static_cast<float>(cell.length);
  ray.mask = std::numeric_limits<unsigned>::max();
  return ray;
}

std::optional<SurfaceHit> TiledScene::Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                                                double t_max) const {
  std::optional<SurfaceHit> result;
  Walk(origin, dir, t_min, t_max, [&](const CellRay& cell) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit query{};
    query.ray = EmbreeRay(cell, dir);
    // Embree holds the ray in single precision, which can put a surface
    // exactly at t_max just outside the closed interval (absolute rounding of
    // the origin matters most on a short last span). Let it look a cell
    // margin further; the double-precision refinement below decides.
    query.ray.tfar = static_cast<float>(cell.length + margin_);
    query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    query.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_.get(), &context, &query);
    if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;

    // Refine in double precision on the triangle Embree found.
    const std::uint32_t prim = query.hit.primID;
    const Eigen::Vector3i& tri = geometry_.triangles[prim_triangle_[prim]];
    const Eigen::Vector3d shift(prim_shift_[prim][0] * tile_size_mm(), prim_shift_[prim][1] * tile_size_mm(), 0.0);
    const Eigen::Vector3d a = geometry_.vertices[tri[0]] + shift;
    const Eigen::Vector3d n = (geometry_.vertices[tri[1]] - geometry_.vertices[tri[0]])
                                  .cross(geometry_.vertices[tri[2]] - geometry_.vertices[tri[0]]);
    const double cos_n = n.dot(dir);
    double s = query.ray.tfar;
    // A ray (nearly) in the triangle's plane has no stable plane
    // intersection; Embree's single-precision parameter is then the better one.
    if (std::abs(cos_n) > 1e-9 * n.norm()) s = n.dot(a - cell.origin) / cos_n;
    // Beyond the interval (found only through the slack above): no hit here,
    // and none nearer, since Embree returns the closest.
    if (s > cell.length * (1.0 + 1e-12) + 1e-12) return false;
    s = std::clamp(s, 0.0, cell.length);

    SurfaceHit hit;
    hit.distance = cell.t_offset + s;
    hit.point = origin + hit.distance * dir;
    hit.normal = n.normalized();
    if (hit.normal.dot(dir) > 0.0) hit.normal = -hit.normal;
    const Eigen::Vector3d in_cell = cell.origin + s * dir;
    hit.reflectance = ReflectanceAt(geometry_, geometry_.triangle_part[prim_triangle_[prim]], in_cell.x(), in_cell.y());
    result = hit;
    return true;
  });
  return result;
}

bool TiledScene::Occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double t_max) const {
  return Walk(origin, dir, t_min, t_max, [&](const CellRay& cell) {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay query = EmbreeRay(cell, dir);
    rtcOccluded1(scene_.get(), &context, &query);
    return query.tfar < 0.0f;  // Embree sets tfar to -inf on a hit
  });
}

}  // namespace

std::unique_ptr<MesostructureScene> MakeTiledScene(TileGeometry geometry) {
  CheckTileGeometry(geometry);
  return std::make_unique<TiledScene>(std::move(geometry));
}

}  // namespace mesocap::sim
