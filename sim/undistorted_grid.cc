#include "sim/undistorted_grid.h"

#include <algorithm>
#include <new>
#include <string>
#include <thread>

#include "core/error.h"
#include "sim/camera_renderer.h"

namespace mesocap::sim {

PixelRect PixelRect::Union(const PixelRect& other) const {
  return {std::min(x0, other.x0), std::min(y0, other.y0), std::max(x1, other.x1), std::max(y1, other.y1)};
}

Eigen::Vector2d UndistortedGrid::Compute(const formats::CameraCalibration& camera, int n, int x, int y, int s) {
  const formats::Intrinsics& k = camera.intrinsics;
  const double u = x + ((s % n) + 0.5) / n - 0.5, v = y + ((s / n) + 0.5) / n - 0.5;
  return Undistort(camera.distortion, Eigen::Vector2d((u - k.cx) / k.fx, (v - k.cy) / k.fy));
}

UndistortedGrid::UndistortedGrid(const formats::CameraCalibration& camera, int samples_per_pixel_side, PixelRect rect)
    : camera_(camera), n_(samples_per_pixel_side), rect_(rect) {
  const int width = rect.x1 - rect.x0, height = rect.y1 - rect.y0;
  if (width <= 0 || height <= 0) return;
  const auto pixels = static_cast<std::size_t>(width) * height;
  const std::size_t count = pixels * n_ * n_;
  try {
    state_ = std::make_unique<std::atomic<std::uint8_t>[]>(pixels);  // zero: kEmpty
    values_.reset(new Eigen::Vector2d[count]);                       // no initialization: pages stay untouched
  } catch (const std::bad_alloc&) {
    core::ThrowOutOfMemory(count * sizeof(Eigen::Vector2d), "the undistorted rays of " + std::to_string(width) + " x " +
                                                                std::to_string(height) + " pixels, " +
                                                                std::to_string(n_ * n_) + " a pixel");
  }
}

const Eigen::Vector2d* UndistortedGrid::Pixel(int x, int y) const {
  const std::size_t pixel = static_cast<std::size_t>(y - rect_.y0) * (rect_.x1 - rect_.x0) + (x - rect_.x0);
  Eigen::Vector2d* values = &values_[pixel * n_ * n_];
  std::atomic<std::uint8_t>& state = state_[pixel];
  if (state.load(std::memory_order_acquire) == kDone) return values;
  std::uint8_t expected = kEmpty;
  if (state.compare_exchange_strong(expected, kFilling, std::memory_order_acq_rel)) {
    for (int s = 0; s < n_ * n_; ++s) values[s] = Compute(camera_, n_, x, y, s);
    state.store(kDone, std::memory_order_release);
    return values;
  }
  // Another thread is computing this pixel: a few microseconds.
  while (state.load(std::memory_order_acquire) != kDone) std::this_thread::yield();
  return values;
}

}  // namespace mesocap::sim
