#include "sim/undistorted_grid.h"

#include <tbb/parallel_for.h>

#include <cstdint>
#include <string>

#include "core/error.h"
#include "sim/camera_renderer.h"

namespace mesocap::sim {

Eigen::Vector2d UndistortedGrid::Compute(const formats::CameraCalibration& camera, int n, int x, int y, int s) {
  const formats::Intrinsics& k = camera.intrinsics;
  const double u = x + ((s % n) + 0.5) / n - 0.5, v = y + ((s / n) + 0.5) / n - 0.5;
  return Undistort(camera.distortion, Eigen::Vector2d((u - k.cx) / k.fx, (v - k.cy) / k.fy));
}

UndistortedGrid::UndistortedGrid(const formats::CameraCalibration& camera, int samples_per_pixel_side, PixelRect rect)
    : n_(samples_per_pixel_side), rect_(rect) {
  const int width = rect.x1 - rect.x0, height = rect.y1 - rect.y0;
  if (width <= 0 || height <= 0) return;
  const auto count = static_cast<std::uint64_t>(width) * height * n_ * n_;
  core::CheckMemoryFor(count * sizeof(Eigen::Vector2d), "the undistorted rays of " + std::to_string(width) + " x " +
                                                            std::to_string(height) + " pixels, " +
                                                            std::to_string(n_ * n_) + " a pixel");
  values_.resize(count);
  tbb::parallel_for(rect.y0, rect.y1, [&](int y) {
    for (int x = rect.x0; x < rect.x1; ++x) {
      for (int s = 0; s < n_ * n_; ++s) {
        values_[(static_cast<std::size_t>(y - rect.y0) * width + (x - rect.x0)) * n_ * n_ + s] =
            Compute(camera, n_, x, y, s);
      }
    }
  });
}

}  // namespace mesocap::sim
