// Photos of a calibration board (calibration/board_print.h) as a camera of
// the simulated rig takes them: the print, posed anywhere in the world,
// through the camera's exact pinhole and Brown-Conrady model (the
// simulator's own, sim/camera_renderer.h), supersampled so edges are
// antialiased as a defocus-free lens and a sensor's pixel area average them.
// Lighting is uniform: the photo's signal is the print's reflectance times a
// white level. The sensor (noise, quantization, saturation) is
// sim/camera_sensor.h's, applied after.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "calibration/board_print.h"
#include "core/error.h"
#include "core/image.h"
#include "core/rigid_transform.h"
#include "formats/calibration.h"
#include "sim/undistorted_grid.h"

namespace mesocap::sim {

struct BoardPhotoOptions {
  int samples_per_pixel_side = 4;  // 1..16, on a regular grid in the pixel
  double white_signal = 0.8;       // signal of white paper, fraction of full scale
  double ink_reflectance = 0.05;   // black ink, relative to white paper
  double background_signal = 0.2;  // wherever the ray misses the print
  core::CheckResult Check() const;
};

// The linear signal (one channel, fraction of full scale) of `camera`'s photo
// of `print` with world <- board = `world_from_board`. The print is seen
// from the side its z axis points away from; from behind the board reads as
// background. `grid`, when given, holds the camera's undistorted samples
// over the whole image at the options' samples per pixel side.
core::Image RenderBoardPhoto(const calibration::BoardPrint& print, const core::RigidTransform& world_from_board,
                             const formats::CameraCalibration& camera, const BoardPhotoOptions& options,
                             const UndistortedGrid* grid = nullptr);

// turntable <- board for the board on its holder in the simulated rig: the
// printed side up (the board frame's z down), its centre on the turntable's
// axis height_mm above the reference plane, tilted by tilt_rad about the
// turntable's x axis through that centre.
core::RigidTransform BoardOnHolder(const calibration::CalibrationBoard& board, double height_mm, double tilt_rad);

// Where each of the board's inner corners lands in the photo (NaN behind the
// camera): the truth a corner detector is measured against.
std::vector<Eigen::Vector2d> TrueCornerPixels(const calibration::CalibrationBoard& board,
                                              const core::RigidTransform& world_from_board,
                                              const formats::CameraCalibration& camera);

}  // namespace mesocap::sim
