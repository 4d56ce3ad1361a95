#include "mdf/displacement_image.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "core/plane.h"
#include "formats/rig_description.h"
#include "formats/sweep_analysis.h"
#include "mdf/frame_plane.h"

namespace mesocap::mdf {

core::CheckResult TextureGrid::Check() const {
  if (auto problem = core::CheckImageSize(width, height, "texture size"); !problem.empty()) return problem;
  if (!(sample_size_mm > 0 && std::isfinite(sample_size_mm))) return "sample_size_mm must be positive";
  return {};
}

core::CheckResult TriangulationOptions::Check() const {
  if (!(min_ray_plane_sine > 0 && min_ray_plane_sine < 1)) return "min_ray_plane_sine must be in (0, 1)";
  if (!(max_height_mm >= 0)) return "max_height_mm must be >= 0";
  if (!(backing_depth_mm >= 0 && std::isfinite(backing_depth_mm))) return "backing_depth_mm must be >= 0";
  if (!(max_depth_step_ratio > 0) || !(max_depth_step_texels >= 0)) return "depth step limits must be positive";
  if (!(edge_shift_weight >= 0 && edge_shift_weight <= 1)) return "edge_shift_weight must be in [0, 1]";
  return {};
}

// Half the clearance the rig keeps between the mesostructure and its backing
// (formats::kMinBackingClearanceMm): points within it of the board are on
// the board.
constexpr double kBackingMarginMm = 0.5 * formats::kMinBackingClearanceMm;

SweepPoints TriangulateSweep(const formats::SweepAnalysis& analysis, const calibration::CameraRays& rays,
                             const core::RigidTransform& world_from_sample, const TriangulationOptions& options) {
  if (analysis.width != rays.width() || analysis.height != rays.height()) {
    throw core::Error("triangulation: sweep analysis and camera differ in image size");
  }
  const core::RigidTransform sample_from_world = world_from_sample.Inverse();
  auto triangulate = [&](const std::vector<float>& times) {
    const float nan = std::numeric_limits<float>::quiet_NaN();
    std::vector<Eigen::Vector3f> points(static_cast<std::size_t>(analysis.width) * analysis.height,
                                        Eigen::Vector3f::Constant(nan));
    for (int y = 0; y < analysis.height; ++y) {
      for (int x = 0; x < analysis.width; ++x) {
        const std::size_t p = static_cast<std::size_t>(y) * analysis.width + x;
        const float t = times[p];
        if (std::isnan(t)) continue;
        const core::Plane plane = PlaneAtTime(analysis.planes, t);
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
  };
  SweepPoints points;
  points.first = triangulate(analysis.peak_time);
  points.brightness = analysis.peak_value;
  if (analysis.second_time.size() == analysis.peak_time.size()) points.second = triangulate(analysis.second_time);
  return points;
}

namespace {

struct Vertex {
  double u, v, d;  // texel coordinates (texel i centred at u = i), distance
  double fill_penalty = 0;  // texels added to the vertex's distance in the nearest-vertex fill
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
        const double da = std::hypot(a.u - i, a.v - j) + a.fill_penalty;
        const double db = std::hypot(b.u - i, b.v - j) + b.fill_penalty;
        const double dc = std::hypot(c.u - i, c.v - j) + c.fill_penalty;
        interpolated = da <= db && da <= dc ? a.d : (db <= dc ? b.d : c.d);
      }
      const float d = static_cast<float>(std::max(0.0, interpolated));
      float& out = (*distance)[static_cast<std::size_t>(j) * grid.width + i];
      if (std::isnan(out) || d < out) out = d;
    }
  }
}

}  // namespace

DisplacementImage ResampleToTexture(const SweepPoints& points, int pixel_width, int pixel_height,
                                    const Eigen::Vector3d& view, const TextureGrid& grid,
                                    const TriangulationOptions& options) {
  const std::size_t n = static_cast<std::size_t>(pixel_width) * pixel_height;
  if (points.first.size() != n || (!points.second.empty() && points.second.size() != n)) {
    throw core::Error("displacement image: point count does not match the image size");
  }
  if (!(view.z() > 1e-6)) throw core::Error("displacement image: the view direction must point above the reference plane");
  DisplacementImage out;
  out.width = grid.width;
  out.height = grid.height;
  out.distance_mm.assign(static_cast<std::size_t>(grid.width) * grid.height,
                         std::numeric_limits<float>::quiet_NaN());
  const Eigen::Vector3d v = view.normalized();
  const double texel_u = grid.sample_size_mm / grid.width;
  const double texel_v = grid.sample_size_mm / grid.height;
  // A point's vertex; false where the point is unknown.
  auto project = [&](const Eigen::Vector3f& point, Vertex* vertex) {
    if (!point.allFinite()) return false;
    const Eigen::Vector3d q = point.cast<double>();
    // p_ref = q + D v on z = 0; D >= 0 (a point a hair above the plane is 0).
    const double d = std::max(0.0, -q.z() / v.z());
    const Eigen::Vector3d ref = q + d * v;
    const bool on_backing = options.backing_depth_mm > 0 && q.z() < -options.backing_depth_mm + kBackingMarginMm;
    *vertex = {(ref.x() + 0.5 * grid.sample_size_mm) / texel_u - 0.5,
               (ref.y() + 0.5 * grid.sample_size_mm) / texel_v - 0.5,
               on_backing ? std::numeric_limits<double>::infinity() : d};
    return true;
  };
  std::vector<Vertex> vertices(n);
  std::vector<bool> valid(n, false);
  for (std::size_t p = 0; p < n; ++p) valid[p] = project(points.first[p], &vertices[p]);
  const double texel = std::min(texel_u, texel_v);
  auto step_limit = [&](double extent_texels) {
    return options.max_depth_step_ratio * texel * extent_texels + options.max_depth_step_texels * texel;
  };
  auto continuous_pair = [&](const Vertex& a, const Vertex& b) {
    return std::abs(a.d - b.d) <= step_limit(std::hypot(a.u - b.u, a.v - b.v));
  };
  auto continuous = [&](const Vertex& a, const Vertex& b, const Vertex& c) {
    const double extent = std::max({std::hypot(a.u - b.u, a.v - b.v), std::hypot(b.u - c.u, b.v - c.v),
                                    std::hypot(c.u - a.u, c.v - a.v)});
    const double spread = std::max({a.d, b.d, c.d}) - std::min({a.d, b.d, c.d});
    return spread <= step_limit(extent);
  };
  // Pixels straddling an occluding edge: the second point continues the
  // surface of a 4-neighbour whose first point is across a discontinuity
  // from this pixel's first. Such a pixel is a vertex of both surfaces: of
  // the near one in `vertices`, of the far one in `far`. The tests read the
  // first points only (`vertices` changes after them), so the result does
  // not depend on the scan order.
  // A pixel's 4-neighbour, where it lies in the image with a point off the
  // board (kNone otherwise).
  constexpr std::array<std::pair<int, int>, 4> kNeighbours = {{{-1, 0}, {1, 0}, {0, -1}, {0, 1}}};
  constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
  auto surface_pixel = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= pixel_width || y >= pixel_height) return kNone;
    const std::size_t q = static_cast<std::size_t>(y) * pixel_width + x;
    return valid[q] && !std::isinf(vertices[q].d) ? q : kNone;
  };
  std::vector<Vertex> far;
  std::vector<bool> straddles;
  if (!points.second.empty()) {
    for (int y = 0; y < pixel_height; ++y) {
      for (int x = 0; x < pixel_width; ++x) {
        const std::size_t p = static_cast<std::size_t>(y) * pixel_width + x;
        Vertex second;
        if (!valid[p] || std::isinf(vertices[p].d) || !project(points.second[p], &second) || std::isinf(second.d)) {
          continue;
        }
        bool edge = false;
        for (const auto& [dx, dy] : kNeighbours) {
          const std::size_t q = surface_pixel(x + dx, y + dy);
          if (q == kNone) continue;
          edge = edge || (continuous_pair(second, vertices[q]) && !continuous_pair(vertices[p], vertices[q]));
        }
        if (!edge) continue;
        if (far.empty()) {
          far = vertices;
          straddles.assign(n, false);
        }
        straddles[p] = true;
        far[p] = second;
      }
    }
    for (std::size_t p = 0; p < straddles.size(); ++p) {
      if (straddles[p] && far[p].d < vertices[p].d) std::swap(vertices[p], far[p]);
    }
  }
  // Near-side edge pixels without a second point (see edge_shift_weight):
  // with near share f of the footprint, the edge lies f - 1/2 pixels past
  // the pixel's centre rather than 1/2. Penalizing the pixel's vertex by
  // 2 w (1 - f) pixels in the nearest-vertex fill moves the fill's boundary
  // with the far neighbour by w (1 - f) pixels towards it.
  if (options.edge_shift_weight > 0 && points.brightness.size() == n) {
    for (int y = 0; y < pixel_height; ++y) {
      for (int x = 0; x < pixel_width; ++x) {
        const std::size_t p = static_cast<std::size_t>(y) * pixel_width + x;
        if (!valid[p] || std::isinf(vertices[p].d) || (!straddles.empty() && straddles[p])) continue;
        for (const auto& [dx, dy] : kNeighbours) {
          const std::size_t far_side = surface_pixel(x + dx, y + dy);
          const std::size_t same_side = surface_pixel(x - dx, y - dy);
          if (far_side == kNone || same_side == kNone || !(points.brightness[same_side] > 0)) continue;
          Vertex& near = vertices[p];
          const Vertex& beyond = vertices[far_side];
          const Vertex& before = vertices[same_side];
          if (!(beyond.d > near.d) || continuous_pair(near, beyond) || !continuous_pair(near, before)) continue;
          const double share = std::clamp(points.brightness[p] / points.brightness[same_side], 0.0f, 1.0f);
          const double pixel = std::hypot(near.u - before.u, near.v - before.v);
          near.fill_penalty = std::max(near.fill_penalty, 2.0 * options.edge_shift_weight * (1.0 - share) * pixel);
        }
      }
    }
  }
  // Pass 1 interpolates across continuous triangles; pass 2 fills texels
  // still unknown from triangles across a discontinuity, nearest vertex
  // first, so an edge is placed to within half a pixel instead of leaving a
  // pixel-wide strip unknown along every edge.
  std::vector<float> edges(out.distance_mm.size(), std::numeric_limits<float>::quiet_NaN());
  // One surface's triangles; with only_straddling, those of quads with a
  // corner that straddles an edge (the other quads are the same in both).
  auto rasterize_surface = [&](const std::vector<Vertex>& surface, bool only_straddling) {
    for (int y = 0; y + 1 < pixel_height; ++y) {
      for (int x = 0; x + 1 < pixel_width; ++x) {
        const std::size_t p00 = static_cast<std::size_t>(y) * pixel_width + x;
        const std::size_t p10 = p00 + 1, p01 = p00 + pixel_width, p11 = p01 + 1;
        if (only_straddling && !(straddles[p00] || straddles[p10] || straddles[p01] || straddles[p11])) continue;
        // A quad with one unknown corner (a pixel in the laser's shadow, or
        // too dim, next to measured ones) still has the triangle of its other
        // three corners, so a single unknown pixel does not open a hole a
        // pixel wide around itself. That triangle is used only where it is
        // continuous and off the board: its missing corner may have been the
        // far side of an edge or a hole's rim, so it never places either.
        const int unknown = !valid[p00] + !valid[p10] + !valid[p01] + !valid[p11];
        if (unknown > 1) continue;
        const bool fallback = unknown == 1;
        std::array<std::array<std::size_t, 3>, 2> triangles = {std::array{p00, p10, p11},
                                                               std::array{p00, p11, p01}};
        if (fallback) {
          int corner = 0;
          for (const std::size_t p : {p00, p10, p11, p01}) {
            if (valid[p]) triangles[0][corner++] = p;
          }
        }
        for (int k = 0; k < (fallback ? 1 : 2); ++k) {
          const Vertex& a = surface[triangles[k][0]];
          const Vertex& b = surface[triangles[k][1]];
          const Vertex& c = surface[triangles[k][2]];
          const int on_board = std::isinf(a.d) + std::isinf(b.d) + std::isinf(c.d);
          if (fallback && on_board > 0) continue;
          if (on_board == 3) {
            // All three saw the board: the texels between them look through
            // the hole too (no hit, each its nearest vertex's), unless a
            // surface covers them.
            Rasterize(a, b, c, grid, true, &out.distance_mm);
            continue;
          }
          // Across a hole's rim (a surface and the board) nothing is filled:
          // a texel there is no hit or a surface to within a pixel, and a
          // false hit would close the hole (sponge: false hits 0.052 -> 0.072).
          if (on_board > 0) continue;
          const bool smooth = continuous(a, b, c);
          // Edges are placed from the near surface only: where a pixel
          // straddles one, the far surface's continuous triangles cover
          // the texels beyond its centre first.
          if (smooth || (options.fill_discontinuities && !fallback && !only_straddling)) {
            Rasterize(a, b, c, grid, !smooth, smooth ? &out.distance_mm : &edges);
          }
        }
      }
    }
  };
  rasterize_surface(vertices, false);
  if (!far.empty()) rasterize_surface(far, true);
  for (std::size_t t = 0; t < edges.size(); ++t) {
    if (std::isnan(out.distance_mm[t])) out.distance_mm[t] = edges[t];
  }
  return out;
}

}  // namespace mesocap::mdf
