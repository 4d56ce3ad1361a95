// The undistorted normalized image coordinates of a camera's sub-pixel
// samples over a rectangle of pixels, each pixel's computed once, when a
// photo first needs it: the simulator's Undistort (sim/camera_renderer.h)
// iterates to double precision, and a calibration session's board and
// mirror-sphere photos ask it again for the same rays at every photo. A
// mirror-sphere photo needs the fine samples of few pixels (the sphere's
// outline and the lamps' images), so only those are ever computed.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <memory>

#include "formats/calibration.h"

namespace mesocap::sim {

struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // [x0, x1) x [y0, y1)
  bool operator==(const PixelRect&) const = default;
  bool Contains(const PixelRect& other) const {
    return other.x0 >= x0 && other.y0 >= y0 && other.x1 <= x1 && other.y1 <= y1;
  }
  // The smallest rectangle holding both.
  PixelRect Union(const PixelRect& other) const;
};

class UndistortedGrid {
 public:
  // Sample s < n^2 of pixel (x, y) lies at u = x + ((s % n) + 0.5) / n - 0.5,
  // v = y + ((s / n) + 0.5) / n - 0.5. Nothing is computed yet; the table's
  // memory is taken from the system page by page as pixels are first asked
  // for. Throws Error when it cannot be reserved.
  UndistortedGrid(const formats::CameraCalibration& camera, int samples_per_pixel_side, PixelRect rect);

  // The same values as Pixel, without a table.
  static Eigen::Vector2d Compute(const formats::CameraCalibration& camera, int samples_per_pixel_side, int x, int y,
                                 int s);

  int samples_per_pixel_side() const { return n_; }
  const PixelRect& rect() const { return rect_; }
  // The n^2 samples of pixel (x, y), inside rect(), in the order of s;
  // computed on the first call for the pixel. Safe to call from any thread.
  const Eigen::Vector2d* Pixel(int x, int y) const;

 private:
  formats::CameraCalibration camera_;
  int n_ = 1;
  PixelRect rect_;
  // Per pixel: not computed, being computed by a thread, or done.
  enum State : std::uint8_t { kEmpty, kFilling, kDone };
  std::unique_ptr<std::atomic<std::uint8_t>[]> state_;
  std::unique_ptr<Eigen::Vector2d[]> values_;  // left uninitialized until a pixel is computed
};

}  // namespace mesocap::sim
