// Displacement images (MDF paper Sec. 3.2, "Initial displacement images"):
// the space-time result of one sweep triangulated against the laser planes,
// then resampled to the texture grid as D along the view direction.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "calibration/camera_rays.h"
#include "calibration/texel_grid.h"
#include "core/error.h"
#include "core/rigid_transform.h"
#include "formats/sweep_analysis.h"
#include "mdf/space_time_analyzer.h"

namespace mesocap::mdf {

struct TriangulationOptions {
  // Ill-conditioning (Sec. 3.2 cites the error analysis of shadow scanning):
  // a plane error e moves the intersection by e / |ray . n|; rays closer to
  // the laser plane than this sine are rejected rather than turned into
  // wild points (0.03: at most 33x amplification; the merge's median test
  // removes what is still off when another scan sees the texel).
  double min_ray_plane_sine = 0.03;
  // Mesostructure lies below the reference plane; points higher than this
  // (mm) are triangulation failures.
  double max_height_mm = 0.1;
  // The rig's backing board (formats::SampleBacking; 0: none). A point on it
  // (deeper than half the board's clearance above it) was seen through a
  // hole: "no hit" evidence for its texel. Points deeper still than that
  // below the board are triangulation failures.
  double backing_depth_mm = 0.0;
  // Resampling: a triangle of neighbouring pixels whose D values spread more
  // than ratio x its texture-space extent + texels x texel width spans a
  // depth discontinuity (an occluding edge) and is not interpolated. A
  // slope of 2 is 63 degrees from the reference plane along the view; a
  // ratio of 3 (72 degrees) bridged the weave's thread-to-thread steps
  // once pixels straddling an edge became vertices of both surfaces (small
  // rig, weave: texels off by more than a texel 5.40 % -> 5.16 %).
  double max_depth_step_ratio = 2.0;
  double max_depth_step_texels = 1.0;
  // Texels left unknown between measurements across a discontinuity take
  // the nearest measurement's D (the edge is then placed to half a pixel).
  bool fill_discontinuities = true;
  // An occluding edge's near-side pixel with no second peak may straddle
  // the edge all the same: the far surface's stripe came too close in time
  // to separate, or too dim (weave, small rig, turntable 60, 56.25-degree
  // view: 3 in 4 near-side edge pixels have no second peak, and for 7 in 10
  // of those the far neighbour peaked under 5 frames away). Its brightness
  // over that of its neighbour on the same surface estimates the share of
  // its footprint the near surface covers, and the fill moves the edge
  // towards the pixel's centre by this weight times what that share
  // indicates. The estimate is noisy (the stripe's profile and the surface's
  // shading change the ratio too), so the weight halves it; 0 places such
  // edges midway between the pixels (weave, small rig, whole session, p95
  // at weights 0 / 0.25 / 0.5 / 0.75 / 1: 1.012 / 0.914 / 0.898 / 0.921 /
  // 0.940). The far side's ratio is not used: the near edge also shadows
  // it from the laser.
  double edge_shift_weight = 0.5;

  core::CheckResult Check() const;
};

// The mesostructure points (sample frame) seen by each pixel (row-major):
// the pixel's ray met with the laser plane at its peak time (planes blended
// between frames), and at its second peak's time. NaN where the pixel has
// no such peak, its plane is invalid, or the intersection is ill-conditioned
// or above the reference plane.
struct SweepPoints {
  std::vector<Eigen::Vector3f> first;
  std::vector<Eigen::Vector3f> second;  // empty, or one per pixel
  std::vector<float> brightness;        // the first peak's value; empty, or one per pixel
};
SweepPoints TriangulateSweep(const formats::SweepAnalysis& analysis, const calibration::CameraRays& rays,
                             const core::RigidTransform& world_from_sample, const TriangulationOptions& options);

// D(x, y) for one view and one laser location on the texture grid: distance
// in mm from the texel's reference point along -view (sample frame, unit,
// towards the camera) to the measured surface; +infinity (no hit, as in
// core/mdf.h) where the texel's ray was seen to reach the backing; NaN
// (unknown) where nothing was measured. Unknown pixels stay unknown; no
// value is invented across a discontinuity.
struct DisplacementImage {
  int width = 0;
  int height = 0;
  std::vector<float> distance_mm;

  float at(int i, int j) const { return distance_mm[static_cast<std::size_t>(j) * width + i]; }
};

// Resamples the per-pixel points (pixel_width x pixel_height, from
// TriangulateSweep) to the grid: each point projects along `view` to the
// reference plane (p = q + D view), neighbouring pixels form triangles that
// are rasterized at texel centres with D interpolated, and the nearest
// surface (smallest D, the first hit) wins where triangles overlap; a quad of
// pixels with one unknown corner gives the triangle of its other three where
// that is continuous and off the board. Points on
// the backing (options.backing_depth_mm) give "no hit", which any surface
// covering the texel overrides.
//
// A pixel whose first point is discontinuous with a 4-neighbour's while its
// second point continues that neighbour's surface straddles an occluding
// edge: it is a vertex of both surfaces, so the edge is placed at the
// pixel's centre rather than at its far side (which the brighter, usually
// nearer, surface alone would give). Other second points (interreflection
// ghosts, points on the backing) are not used. A near-side pixel with no
// such second point moves the edge by its brightness instead
// (TriangulationOptions::edge_shift_weight).
DisplacementImage ResampleToTexture(const SweepPoints& points, int pixel_width, int pixel_height,
                                    const Eigen::Vector3d& view, const calibration::TexelGrid& grid,
                                    const TriangulationOptions& options);

}  // namespace mesocap::mdf
