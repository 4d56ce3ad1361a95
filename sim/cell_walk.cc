#include "sim/cell_walk.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace mesocap::sim {

CellWalk::CellWalk(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double t_max,
                   double tile_size_mm, double d_max_mm)
    : origin_(origin), dir_(dir), tile_size_(tile_size_mm), t_(t_min), t_end_(t_max) {
  if (!origin.allFinite() || !dir.allFinite() || !std::isfinite(t_min) || std::isnan(t_max)) {
    throw std::invalid_argument("CellWalk: ray origin, direction and t_min must be finite");
  }
  if (dir.z() != 0.0) {
    const double t_top = -origin.z() / dir.z();
    const double t_bottom = (-d_max_mm - origin.z()) / dir.z();
    t_ = std::max(t_, std::min(t_top, t_bottom));
    t_end_ = std::min(t_end_, std::max(t_top, t_bottom));
  } else if (origin.z() > 0.0 || origin.z() < -d_max_mm) {
    done_ = true;  // horizontal and outside the slab
  }
  if (!(t_ <= t_end_)) done_ = true;
  if (done_) return;

  const Eigen::Vector3d start = origin + t_ * dir;
  // Cell indices must stay exactly representable; 2^50 tiles is far beyond any rig.
  constexpr double kMaxIndex = 0x1p50;
  const double ci = std::floor(start.x() / tile_size_);
  const double cj = std::floor(start.y() / tile_size_);
  if (std::abs(ci) > kMaxIndex || std::abs(cj) > kMaxIndex) {
    throw std::invalid_argument("CellWalk: ray starts too far from the sample");
  }
  i_ = static_cast<std::int64_t>(ci);
  j_ = static_cast<std::int64_t>(cj);
}

double CellWalk::NextBorder(int axis, std::int64_t cell) const {
  const double d = dir_[axis];
  // Borders are computed from the cell index, never accumulated, so the walk
  // does not drift over many cells.
  if (d > 0.0) return (static_cast<double>(cell + 1) * tile_size_ - origin_[axis]) / d;
  if (d < 0.0) return (static_cast<double>(cell) * tile_size_ - origin_[axis]) / d;
  return std::numeric_limits<double>::infinity();
}

bool CellWalk::Next(CellSpan* span) {
  if (done_) return false;
  if (cells_ == kMaxCellsPerRay) {
    done_ = true;
    return false;
  }
  const double tx = NextBorder(0, i_);
  const double ty = NextBorder(1, j_);
  // A start point rounded onto the far side of a border gives a border
  // parameter slightly behind t_: the span is then empty, not negative.
  const double end = std::max(t_, std::min({tx, ty, t_end_}));
  *span = {i_, j_, t_, end};
  ++cells_;
  if (end >= t_end_) {
    done_ = true;
    return true;
  }
  t_ = end;
  // On a tie (through a corner) step in x now and in y on the next call,
  // which visits the corner cell with an empty span: slower, never wrong.
  if (tx <= ty) {
    i_ += dir_.x() > 0.0 ? 1 : -1;
  } else {
    j_ += dir_.y() > 0.0 ? 1 : -1;
  }
  return true;
}

}  // namespace mesocap::sim
