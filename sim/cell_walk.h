// The tile cells a ray crosses inside the mesostructure slab, in ray order:
// cell (i, j) is [i P, (i+1) P) x [j P, (j+1) P) x [-d_max, 0]. The tiled
// tracer queries one cell at a time, so a ray costs one query per cell it
// crosses instead of one per tile copy in the scene.
#pragma once

#include <Eigen/Core>
#include <cstdint>

namespace mesocap::sim {

// A ray that would cross more cells than this inside the slab is cut off
// there (the tracer then reports no hit). Crossing the slab takes about
// d_max tan(theta) (|cos phi| + |sin phi|) / P cells, so the cap is only
// reached within ~0.02 degrees of horizontal for the built-in scenes; it
// exists because an exactly horizontal ray in a periodic gap never leaves.
inline constexpr int kMaxCellsPerRay = 4096;

struct CellSpan {
  std::int64_t i = 0;
  std::int64_t j = 0;
  double t_begin = 0.0;  // the ray is in the cell for t in [t_begin, t_end]
  double t_end = 0.0;
};

class CellWalk {
 public:
  // The ray origin + t dir for t in [t_min, t_max], clipped to the slab.
  CellWalk(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double t_max, double tile_size_mm,
           double d_max_mm);

  // The next cell; false once the ray has left the slab or [t_min, t_max],
  // or after kMaxCellsPerRay cells.
  bool Next(CellSpan* span);

 private:
  // Parameter where the ray crosses the next cell border along one axis.
  double NextBorder(int axis, std::int64_t cell) const;

  Eigen::Vector3d origin_;
  Eigen::Vector3d dir_;
  double tile_size_;
  double t_;      // start of the next span
  double t_end_;  // where the ray leaves the slab or its interval
  std::int64_t i_ = 0;
  std::int64_t j_ = 0;
  int cells_ = 0;
  bool done_ = false;
};

}  // namespace mesocap::sim
