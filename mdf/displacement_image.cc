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
  double u, v, d;           // texel coordinates (texel i centred at u = i), distance
  double fill_penalty = 0;  // texels added to the vertex's distance in the nearest-vertex fill
};

// nearest: give each texel the D of its nearest vertex instead of the
// interpolated one (triangles across a depth discontinuity: the edge lies
// somewhere between the vertices, so each texel takes the surface of the
// closest measurement).
void Rasterize(const Vertex& a, const Vertex& b, const Vertex& c, const calibration::TexelGrid& grid, bool nearest,
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

// One sweep's pixels as vertices on the texel grid: each measured point
// projected along the view to the reference plane (p = q + D view, Sec. 3.2's
// displacement from the reference plane along the view), with the
// continuity tests that decide which neighbouring pixels show one surface.
// `near` holds each pixel's first point; `far` the second surface of pixels
// straddling an occluding edge (empty when there are none).
class PixelSurfaces {
 public:
  PixelSurfaces(int pixel_width, int pixel_height, const Eigen::Vector3d& view, const calibration::TexelGrid& grid,
                const TriangulationOptions& options)
      : width_(pixel_width),
        height_(pixel_height),
        n_(static_cast<std::size_t>(pixel_width) * pixel_height),
        grid_(grid),
        options_(options),
        view_(view.normalized()),
        texel_(std::min(grid.texel_width_mm(), grid.texel_height_mm())) {}

  // The first points' vertices; a pixel without a point is unknown.
  void ProjectFirstPoints(const std::vector<Eigen::Vector3f>& first) {
    near_.resize(n_);
    valid_.assign(n_, false);
    for (std::size_t p = 0; p < n_; ++p) valid_[p] = Project(first[p], &near_[p]);
  }

  // Pixels straddling an occluding edge: the second point continues the
  // surface of a 4-neighbour whose first point is across a discontinuity
  // from this pixel's first. Such a pixel is a vertex of both surfaces: of
  // the near one in `near_`, of the far one in `far_`. The tests read the
  // first points only (`near_` changes after them), so the result does
  // not depend on the scan order.
  void AddEdgeStraddlingPixels(const std::vector<Eigen::Vector3f>& second) {
    for (int y = 0; y < height_; ++y) {
      for (int x = 0; x < width_; ++x) {
        const std::size_t p = static_cast<std::size_t>(y) * width_ + x;
        Vertex second_vertex;
        if (!valid_[p] || std::isinf(near_[p].d) || !Project(second[p], &second_vertex) ||
            std::isinf(second_vertex.d)) {
          continue;
        }
        bool edge = false;
        for (const auto& [dx, dy] : kNeighbours) {
          const std::size_t q = SurfacePixel(x + dx, y + dy);
          if (q == kNone) continue;
          edge = edge || (ContinuousPair(second_vertex, near_[q]) && !ContinuousPair(near_[p], near_[q]));
        }
        if (!edge) continue;
        if (far_.empty()) {
          far_ = near_;
          straddles_.assign(n_, false);
        }
        straddles_[p] = true;
        far_[p] = second_vertex;
      }
    }
    for (std::size_t p = 0; p < straddles_.size(); ++p) {
      if (straddles_[p] && far_[p].d < near_[p].d) std::swap(near_[p], far_[p]);
    }
  }

  // Near-side edge pixels without a second point (see edge_shift_weight):
  // with near share f of the footprint, the edge lies f - 1/2 pixels past
  // the pixel's centre rather than 1/2. Penalizing the pixel's vertex by
  // 2 w (1 - f) pixels in the nearest-vertex fill moves the fill's boundary
  // with the far neighbour by w (1 - f) pixels towards it.
  void ShiftEdgesByBrightness(const std::vector<float>& brightness) {
    for (int y = 0; y < height_; ++y) {
      for (int x = 0; x < width_; ++x) {
        const std::size_t p = static_cast<std::size_t>(y) * width_ + x;
        if (!valid_[p] || std::isinf(near_[p].d) || (!straddles_.empty() && straddles_[p])) continue;
        for (const auto& [dx, dy] : kNeighbours) {
          const std::size_t far_side = SurfacePixel(x + dx, y + dy);
          const std::size_t same_side = SurfacePixel(x - dx, y - dy);
          if (far_side == kNone || same_side == kNone || !(brightness[same_side] > 0)) continue;
          Vertex& near = near_[p];
          const Vertex& beyond = near_[far_side];
          const Vertex& before = near_[same_side];
          if (!(beyond.d > near.d) || ContinuousPair(near, beyond) || !ContinuousPair(near, before)) continue;
          const double share = std::clamp(brightness[p] / brightness[same_side], 0.0f, 1.0f);
          const double pixel = std::hypot(near.u - before.u, near.v - before.v);
          near.fill_penalty = std::max(near.fill_penalty, 2.0 * options_.edge_shift_weight * (1.0 - share) * pixel);
        }
      }
    }
  }

  // Pass 1 interpolates across continuous triangles; pass 2 fills texels
  // still unknown from triangles across a discontinuity, nearest vertex
  // first, so an edge is placed to within half a pixel instead of leaving a
  // pixel-wide strip unknown along every edge.
  void RasterizeAndFill(std::vector<float>* distance) const {
    std::vector<float> edges(distance->size(), std::numeric_limits<float>::quiet_NaN());
    RasterizeSurface(near_, false, distance, &edges);
    if (!far_.empty()) RasterizeSurface(far_, true, distance, &edges);
    for (std::size_t t = 0; t < edges.size(); ++t) {
      if (std::isnan((*distance)[t])) (*distance)[t] = edges[t];
    }
  }

 private:
  // A pixel's 4-neighbours.
  static constexpr std::array<std::pair<int, int>, 4> kNeighbours = {{{-1, 0}, {1, 0}, {0, -1}, {0, 1}}};
  static constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

  // A point's vertex; false where the point is unknown.
  bool Project(const Eigen::Vector3f& point, Vertex* vertex) const {
    if (!point.allFinite()) return false;
    const Eigen::Vector3d q = point.cast<double>();
    // p_ref = q + D v on z = 0; D >= 0 (a point a hair above the plane is 0).
    const double d = std::max(0.0, -q.z() / view_.z());
    const Eigen::Vector3d ref = q + d * view_;
    const bool on_backing = options_.backing_depth_mm > 0 && q.z() < -options_.backing_depth_mm + kBackingMarginMm;
    const Eigen::Vector2d uv = grid_.TexelCoordinates(ref.x(), ref.y());
    *vertex = {uv.x(), uv.y(), on_backing ? std::numeric_limits<double>::infinity() : d};
    return true;
  }

  double StepLimit(double extent_texels) const {
    return options_.max_depth_step_ratio * texel_ * extent_texels + options_.max_depth_step_texels * texel_;
  }
  bool ContinuousPair(const Vertex& a, const Vertex& b) const {
    return std::abs(a.d - b.d) <= StepLimit(std::hypot(a.u - b.u, a.v - b.v));
  }
  bool Continuous(const Vertex& a, const Vertex& b, const Vertex& c) const {
    const double extent = std::max(
        {std::hypot(a.u - b.u, a.v - b.v), std::hypot(b.u - c.u, b.v - c.v), std::hypot(c.u - a.u, c.v - a.v)});
    const double spread = std::max({a.d, b.d, c.d}) - std::min({a.d, b.d, c.d});
    return spread <= StepLimit(extent);
  }

  // A pixel's neighbour, where it lies in the image with a point off the
  // board (kNone otherwise).
  std::size_t SurfacePixel(int x, int y) const {
    if (x < 0 || y < 0 || x >= width_ || y >= height_) return kNone;
    const std::size_t q = static_cast<std::size_t>(y) * width_ + x;
    return valid_[q] && !std::isinf(near_[q].d) ? q : kNone;
  }

  // One surface's triangles; with only_straddling, those of quads with a
  // corner that straddles an edge (the other quads are the same in both).
  void RasterizeSurface(const std::vector<Vertex>& surface, bool only_straddling, std::vector<float>* distance,
                        std::vector<float>* edges) const {
    for (int y = 0; y + 1 < height_; ++y) {
      for (int x = 0; x + 1 < width_; ++x) {
        const std::size_t p00 = static_cast<std::size_t>(y) * width_ + x;
        const std::size_t p10 = p00 + 1, p01 = p00 + width_, p11 = p01 + 1;
        if (only_straddling && !(straddles_[p00] || straddles_[p10] || straddles_[p01] || straddles_[p11])) continue;
        // A quad with one unknown corner (a pixel in the laser's shadow, or
        // too dim, next to measured ones) still has the triangle of its other
        // three corners, so a single unknown pixel does not open a hole a
        // pixel wide around itself. That triangle is used only where it is
        // continuous and off the board: its missing corner may have been the
        // far side of an edge or a hole's rim, so it never places either.
        const int unknown = !valid_[p00] + !valid_[p10] + !valid_[p01] + !valid_[p11];
        if (unknown > 1) continue;
        const bool fallback = unknown == 1;
        std::array<std::array<std::size_t, 3>, 2> triangles = {std::array{p00, p10, p11}, std::array{p00, p11, p01}};
        if (fallback) {
          int corner = 0;
          for (const std::size_t p : {p00, p10, p11, p01}) {
            if (valid_[p]) triangles[0][corner++] = p;
          }
        }
        for (int k = 0; k < (fallback ? 1 : 2); ++k) {
          RasterizeTriangle(surface[triangles[k][0]], surface[triangles[k][1]], surface[triangles[k][2]], fallback,
                            only_straddling, distance, edges);
        }
      }
    }
  }

  void RasterizeTriangle(const Vertex& a, const Vertex& b, const Vertex& c, bool fallback, bool only_straddling,
                         std::vector<float>* distance, std::vector<float>* edges) const {
    const int on_board = std::isinf(a.d) + std::isinf(b.d) + std::isinf(c.d);
    if (fallback && on_board > 0) return;
    if (on_board == 3) {
      // All three saw the board: the texels between them look through
      // the hole too (no hit, each its nearest vertex's), unless a
      // surface covers them.
      Rasterize(a, b, c, grid_, true, distance);
      return;
    }
    // Across a hole's rim (a surface and the board) nothing is filled:
    // a texel there is no hit or a surface to within a pixel, and a
    // false hit would close the hole (sponge: false hits 0.052 -> 0.072).
    if (on_board > 0) return;
    const bool smooth = Continuous(a, b, c);
    // Edges are placed from the near surface only: where a pixel
    // straddles one, the far surface's continuous triangles cover
    // the texels beyond its centre first.
    if (smooth || (options_.fill_discontinuities && !fallback && !only_straddling)) {
      Rasterize(a, b, c, grid_, !smooth, smooth ? distance : edges);
    }
  }

  int width_, height_;
  std::size_t n_;
  const calibration::TexelGrid& grid_;
  const TriangulationOptions& options_;
  Eigen::Vector3d view_;  // unit, towards the camera
  double texel_;          // the smaller texel side (mm): the unit of the depth-step limit
  std::vector<Vertex> near_;
  std::vector<bool> valid_;
  std::vector<Vertex> far_;
  std::vector<bool> straddles_;
};

}  // namespace

DisplacementImage ResampleToTexture(const SweepPoints& points, int pixel_width, int pixel_height,
                                    const Eigen::Vector3d& view, const calibration::TexelGrid& grid,
                                    const TriangulationOptions& options) {
  const std::size_t n = static_cast<std::size_t>(pixel_width) * pixel_height;
  if (points.first.size() != n || (!points.second.empty() && points.second.size() != n)) {
    throw core::Error("displacement image: point count does not match the image size");
  }
  if (!(view.z() > 1e-6))
    throw core::Error("displacement image: the view direction must point above the reference plane");
  DisplacementImage out;
  out.width = grid.width;
  out.height = grid.height;
  out.distance_mm.assign(static_cast<std::size_t>(grid.width) * grid.height, std::numeric_limits<float>::quiet_NaN());
  PixelSurfaces surfaces(pixel_width, pixel_height, view, grid, options);
  surfaces.ProjectFirstPoints(points.first);
  if (!points.second.empty()) surfaces.AddEdgeStraddlingPixels(points.second);
  if (options.edge_shift_weight > 0 && points.brightness.size() == n) {
    surfaces.ShiftEdgesByBrightness(points.brightness);
  }
  surfaces.RasterizeAndFill(&out.distance_mm);
  return out;
}

}  // namespace mesocap::mdf
