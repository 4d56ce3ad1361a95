#include "processing/displacement_image.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "drivers/rig_description.h"

namespace mesocap {

CheckResult TextureGrid::Check() const {
  if (width < 1 || height < 1 || width > 16384 || height > 16384) return "texture size must be in 1..16384";
  if (!(sample_size_mm > 0 && std::isfinite(sample_size_mm))) return "sample_size_mm must be positive";
  return {};
}

CheckResult TriangulationOptions::Check() const {
  if (!(min_ray_plane_sine > 0 && min_ray_plane_sine < 1)) return "min_ray_plane_sine must be in (0, 1)";
  if (!(max_height_mm >= 0)) return "max_height_mm must be >= 0";
  if (!(backing_depth_mm >= 0 && std::isfinite(backing_depth_mm))) return "backing_depth_mm must be >= 0";
  if (!(max_depth_step_ratio > 0) || !(max_depth_step_texels >= 0)) return "depth step limits must be positive";
  return {};
}

// Half the clearance the rig keeps between the mesostructure and its backing
// (drivers::kMinBackingClearanceMm): points within it of the board are on
// the board.
constexpr double kBackingMarginMm = 0.5 * drivers::kMinBackingClearanceMm;

std::vector<Eigen::Vector3f> TriangulateSweep(const SweepAnalysis& analysis, const CameraRays& rays,
                                              const RigidTransform& world_from_sample,
                                              const TriangulationOptions& options) {
  if (analysis.width != rays.width() || analysis.height != rays.height()) {
    throw Error("triangulation: sweep analysis and camera differ in image size");
  }
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Eigen::Vector3f> points(static_cast<std::size_t>(analysis.width) * analysis.height,
                                      Eigen::Vector3f::Constant(nan));
  const RigidTransform sample_from_world = world_from_sample.Inverse();
  for (int y = 0; y < analysis.height; ++y) {
    for (int x = 0; x < analysis.width; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * analysis.width + x;
      const float t = analysis.peak_time[p];
      if (std::isnan(t)) continue;
      const Plane plane = PlaneAtTime(analysis.planes, t);
      if (!plane.valid()) continue;
      const Eigen::Vector3d& dir = rays.Ray(x, y);
      const double sine = plane.normal.dot(dir);
      if (std::abs(sine) < options.min_ray_plane_sine) continue;
      const double s = -plane.SignedDistance(rays.centre()) / sine;
      if (!(s > 0)) continue;
      const Eigen::Vector3d q = sample_from_world.Apply(rays.centre() + s * dir);
      if (q.z() > options.max_height_mm) continue;
      if (options.backing_depth_mm > 0 && q.z() < -options.backing_depth_mm - kBackingMarginMm) continue;
      points[p] = q.cast<float>();
    }
  }
  return points;
}

namespace {

struct Vertex {
  double u, v, d;  // texel coordinates (texel i centred at u = i), distance
};

// nearest: give each texel the D of its nearest vertex instead of the
// interpolated one (triangles across a depth discontinuity: the edge lies
// somewhere between the vertices, so each texel takes the surface of the
// closest measurement).
void Rasterize(const Vertex& a, const Vertex& b, const Vertex& c, const TextureGrid& grid, bool nearest,
               std::vector<float>* distance) {
  const double area = (b.u - a.u) * (c.v - a.v) - (c.u - a.u) * (b.v - a.v);
  if (std::abs(area) < 1e-12) return;
  // Far off the grid (a point at a grazing view can project far away): skip
  // before the texel bounds are converted to int.
  constexpr double kFar = 1e7;
  for (const Vertex* x : {&a, &b, &c}) {
    if (!(std::abs(x->u) < kFar && std::abs(x->v) < kFar)) return;
  }
  const int i0 = std::max(0, static_cast<int>(std::ceil(std::min({a.u, b.u, c.u}) - 1e-9)));
  const int i1 = std::min(grid.width - 1, static_cast<int>(std::floor(std::max({a.u, b.u, c.u}) + 1e-9)));
  const int j0 = std::max(0, static_cast<int>(std::ceil(std::min({a.v, b.v, c.v}) - 1e-9)));
  const int j1 = std::min(grid.height - 1, static_cast<int>(std::floor(std::max({a.v, b.v, c.v}) + 1e-9)));
  constexpr double kEdge = -1e-9;  // texels on a shared edge belong to both
  for (int j = j0; j <= j1; ++j) {
    for (int i = i0; i <= i1; ++i) {
      const double wa = ((b.u - i) * (c.v - j) - (c.u - i) * (b.v - j)) / area;
      const double wb = ((c.u - i) * (a.v - j) - (a.u - i) * (c.v - j)) / area;
      const double wc = 1.0 - wa - wb;
      if (wa < kEdge || wb < kEdge || wc < kEdge) continue;
      double interpolated = wa * a.d + wb * b.d + wc * c.d;
      if (nearest) {
        const double da = std::hypot(a.u - i, a.v - j), db = std::hypot(b.u - i, b.v - j),
                     dc = std::hypot(c.u - i, c.v - j);
        interpolated = da <= db && da <= dc ? a.d : (db <= dc ? b.d : c.d);
      }
      const float d = static_cast<float>(std::max(0.0, interpolated));
      float& out = (*distance)[static_cast<std::size_t>(j) * grid.width + i];
      if (std::isnan(out) || d < out) out = d;
    }
  }
}

}  // namespace

DisplacementImage ResampleToTexture(const std::vector<Eigen::Vector3f>& points, int pixel_width, int pixel_height,
                                    const Eigen::Vector3d& view, const TextureGrid& grid,
                                    const TriangulationOptions& options) {
  if (points.size() != static_cast<std::size_t>(pixel_width) * pixel_height) {
    throw Error("displacement image: point count does not match the image size");
  }
  if (!(view.z() > 1e-6)) throw Error("displacement image: the view direction must point above the reference plane");
  DisplacementImage out;
  out.width = grid.width;
  out.height = grid.height;
  out.distance_mm.assign(static_cast<std::size_t>(grid.width) * grid.height,
                         std::numeric_limits<float>::quiet_NaN());
  const Eigen::Vector3d v = view.normalized();
  const double texel_u = grid.sample_size_mm / grid.width;
  const double texel_v = grid.sample_size_mm / grid.height;
  std::vector<Vertex> vertices(points.size());
  std::vector<bool> valid(points.size(), false);
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (!points[p].allFinite()) continue;
    const Eigen::Vector3d q = points[p].cast<double>();
    // p_ref = q + D v on z = 0; D >= 0 (a point a hair above the plane is 0).
    const double d = std::max(0.0, -q.z() / v.z());
    const Eigen::Vector3d ref = q + d * v;
    const bool on_backing = options.backing_depth_mm > 0 && q.z() < -options.backing_depth_mm + kBackingMarginMm;
    vertices[p] = {(ref.x() + 0.5 * grid.sample_size_mm) / texel_u - 0.5,
                   (ref.y() + 0.5 * grid.sample_size_mm) / texel_v - 0.5,
                   on_backing ? std::numeric_limits<double>::infinity() : d};
    valid[p] = true;
  }
  const double texel = std::min(texel_u, texel_v);
  auto continuous = [&](const Vertex& a, const Vertex& b, const Vertex& c) {
    const double extent =
        texel * std::max({std::hypot(a.u - b.u, a.v - b.v), std::hypot(b.u - c.u, b.v - c.v),
                          std::hypot(c.u - a.u, c.v - a.v)});
    const double spread = std::max({a.d, b.d, c.d}) - std::min({a.d, b.d, c.d});
    return spread <= options.max_depth_step_ratio * extent + options.max_depth_step_texels * texel;
  };
  // Pass 1 interpolates across continuous triangles; pass 2 fills texels
  // still unknown from triangles across a discontinuity, nearest vertex
  // first, so an edge is placed to within half a pixel instead of leaving a
  // pixel-wide strip unknown along every edge.
  std::vector<float> edges(out.distance_mm.size(), std::numeric_limits<float>::quiet_NaN());
  for (int y = 0; y + 1 < pixel_height; ++y) {
    for (int x = 0; x + 1 < pixel_width; ++x) {
      const std::size_t p00 = static_cast<std::size_t>(y) * pixel_width + x;
      const std::size_t p10 = p00 + 1, p01 = p00 + pixel_width, p11 = p01 + 1;
      // A quad with one unknown corner (a pixel in the laser's shadow, or
      // too dim, next to measured ones) still has the triangle of its other
      // three corners, so a single unknown pixel does not open a hole a pixel
      // wide around itself. That triangle is used only where it is
      // continuous and off the board: its missing corner may have been the
      // far side of an edge or a hole's rim, so it never places either.
      const int unknown = !valid[p00] + !valid[p10] + !valid[p01] + !valid[p11];
      if (unknown > 1) continue;
      const bool fallback = unknown == 1;
      std::array<std::array<std::size_t, 3>, 2> triangles = {std::array{p00, p10, p11}, std::array{p00, p11, p01}};
      if (fallback) {
        int corner = 0;
        for (const std::size_t p : {p00, p10, p11, p01}) {
          if (valid[p]) triangles[0][corner++] = p;
        }
      }
      for (int k = 0; k < (fallback ? 1 : 2); ++k) {
        const auto& [a, b, c] = triangles[k];
        const int on_board = std::isinf(vertices[a].d) + std::isinf(vertices[b].d) + std::isinf(vertices[c].d);
        if (fallback && on_board > 0) continue;
        if (on_board == 3) {
          // All three saw the board: the texels between them look through
          // the hole too (no hit, each its nearest vertex's), unless a
          // surface covers them.
          Rasterize(vertices[a], vertices[b], vertices[c], grid, true, &out.distance_mm);
          continue;
        }
        // Across a hole's rim (a surface and the board) nothing is filled:
        // a texel there is no hit or a surface to within a pixel, and a false
        // hit would close the hole (sponge: false hits 0.052 -> 0.072).
        if (on_board > 0) continue;
        const bool smooth = continuous(vertices[a], vertices[b], vertices[c]);
        if (smooth || (options.fill_discontinuities && !fallback)) {
          Rasterize(vertices[a], vertices[b], vertices[c], grid, !smooth, smooth ? &out.distance_mm : &edges);
        }
      }
    }
  }
  for (std::size_t t = 0; t < edges.size(); ++t) {
    if (std::isnan(out.distance_mm[t])) out.distance_mm[t] = edges[t];
  }
  return out;
}

}  // namespace mesocap
