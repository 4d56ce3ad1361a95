// The undistorted normalized image coordinates of a camera's sub-pixel
// samples over a rectangle of pixels, computed once: the simulator's
// Undistort (sim/camera_renderer.h) iterates to double precision, and a
// calibration session's board and mirror-sphere photos ask it again for the
// same rays at every photo.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "formats/calibration.h"

namespace mesocap::sim {

struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // [x0, x1) x [y0, y1)
  bool operator==(const PixelRect&) const = default;
};

class UndistortedGrid {
 public:
  // Sample s < n^2 of pixel (x, y) lies at u = x + ((s % n) + 0.5) / n - 0.5,
  // v = y + ((s / n) + 0.5) / n - 0.5. Throws Error when the table would not
  // fit in the machine's memory.
  UndistortedGrid(const formats::CameraCalibration& camera, int samples_per_pixel_side, PixelRect rect);

  // The same values as At, without a table.
  static Eigen::Vector2d Compute(const formats::CameraCalibration& camera, int samples_per_pixel_side, int x, int y,
                                 int s);

  int samples_per_pixel_side() const { return n_; }
  const PixelRect& rect() const { return rect_; }
  // (x, y) inside rect().
  const Eigen::Vector2d& At(int x, int y, int s) const {
    return values_[(static_cast<std::size_t>(y - rect_.y0) * (rect_.x1 - rect_.x0) + (x - rect_.x0)) * n_ * n_ + s];
  }

 private:
  int n_ = 1;
  PixelRect rect_;
  std::vector<Eigen::Vector2d> values_;
};

}  // namespace mesocap::sim
