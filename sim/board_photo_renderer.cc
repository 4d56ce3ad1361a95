#include "sim/board_photo_renderer.h"

#include <tbb/parallel_for.h>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <numbers>

#include "sim/camera_renderer.h"

namespace mesocap::sim {

core::CheckResult BoardPhotoOptions::Check() const {
  if (samples_per_pixel_side < 1 || samples_per_pixel_side > 16) return "samples per pixel side must be 1..16";
  if (!(white_signal >= 0 && white_signal <= 100)) return "white signal must be in [0, 100]";
  if (!(ink_reflectance >= 0 && ink_reflectance <= 1)) return "ink reflectance must be in [0, 1]";
  if (!(background_signal >= 0 && background_signal <= 100)) return "background signal must be in [0, 100]";
  return {};
}

core::Image RenderBoardPhoto(const calibration::BoardPrint& print, const core::RigidTransform& world_from_board,
                             const formats::CameraCalibration& camera, const BoardPhotoOptions& options,
                             const UndistortedGrid* grid) {
  core::ThrowIfInvalid(options.Check(), "board photo");
  // Rays in the board's frame: the plane z = 0 there.
  const core::RigidTransform board_from_camera = world_from_board.Inverse().Compose(camera.pose.transform);
  const Eigen::Vector3d origin = board_from_camera.translation;
  const int n = options.samples_per_pixel_side;
  if (grid && (grid->samples_per_pixel_side() != n || !grid->rect().Contains({0, 0, camera.width, camera.height}))) {
    throw core::Error("board photo: the undistorted grid does not cover the image at the photo's samples");
  }
  core::Image signal(camera.width, camera.height, 1);
  tbb::parallel_for(0, camera.height, [&](int y) {
    for (int x = 0; x < camera.width; ++x) {
      double sum = 0;
      const Eigen::Vector2d* samples = grid ? grid->Pixel(x, y) : nullptr;
      for (int s = 0; s < n * n; ++s) {
        const Eigen::Vector2d m = samples ? samples[s] : UndistortedGrid::Compute(camera, n, x, y, s);
        const Eigen::Vector3d d = board_from_camera.rotation * Eigen::Vector3d(m.x(), m.y(), 1.0);
        // A ray parallel to the print (|d.z| tiny) or meeting it behind the
        // camera sees the background.
        const double t = std::abs(d.z()) < 1e-12 ? -1.0 : -origin.z() / d.z();
        if (t <= 0) {
          sum += options.background_signal;
          continue;
        }
        const Eigen::Vector3d p = origin + t * d;
        // The print faces -z (the board frame's z points into the page); its
        // back is plain and reads as background.
        if (!print.Contains(p.x(), p.y()) || d.z() < 0) {
          sum += options.background_signal;
        } else {
          sum += options.white_signal * (print.IsWhite(p.x(), p.y()) ? 1.0 : options.ink_reflectance);
        }
      }
      signal.at(x, y) = static_cast<float>(sum / (n * n));
    }
  });
  return signal;
}

core::RigidTransform BoardOnHolder(const calibration::CalibrationBoard& board, double height_mm, double tilt_rad) {
  const Eigen::Vector2d middle = 0.5 * (board.PrintedMin() + board.PrintedMax());
  core::RigidTransform pose;
  pose.parent_frame = "turntable";
  pose.child_frame = "board";
  pose.rotation = Eigen::AngleAxisd(tilt_rad + std::numbers::pi, Eigen::Vector3d::UnitX()).toRotationMatrix();
  pose.translation = Eigen::Vector3d(0, 0, height_mm) - pose.rotation * Eigen::Vector3d(middle.x(), middle.y(), 0);
  return pose;
}

std::vector<Eigen::Vector2d> TrueCornerPixels(const calibration::CalibrationBoard& board,
                                              const core::RigidTransform& world_from_board,
                                              const formats::CameraCalibration& camera) {
  std::vector<Eigen::Vector2d> pixels;
  const core::RigidTransform& pose = camera.pose.transform;
  for (int id = 0; id < board.CornerCount(); ++id) {
    const Eigen::Vector3d world = world_from_board.Apply(board.CornerPosition(id));
    const Eigen::Vector3d c = pose.rotation.transpose() * (world - pose.translation);
    pixels.push_back(c.z() > 0 ? ProjectToPixel(camera, world)
                               : Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN()));
  }
  return pixels;
}

}  // namespace mesocap::sim
