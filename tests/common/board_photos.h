// Photos of a calibration board with exact truth, for the calibration tests:
// cameras with known intrinsics, distortion and poses, the board at seeded
// random poses in front of them, rendered by sim/board_photo_renderer.h and
// passed through the simulated sensor (noise, 12 bits, saturation).
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

#include "calibration/board_corner_detector.h"
#include "calibration/board_print.h"
#include "calibration/camera_calibration.h"
#include "core/image.h"
#include "formats/calibration.h"
#include "formats/rig_description.h"
#include "sim/board_photo_renderer.h"
#include "sim/camera_sensor.h"

namespace mesocap::testing {

inline formats::CameraCalibration TestCamera(const std::string &id, double k1 = -0.1) {
  formats::CameraCalibration camera;
  camera.id = id;
  camera.width = 640;
  camera.height = 480;
  camera.intrinsics.fx = 800;
  camera.intrinsics.fy = 802;
  camera.intrinsics.cx = 322.5;
  camera.intrinsics.cy = 237.0;
  camera.distortion.k1 = k1;
  camera.distortion.k2 = 0.05;
  camera.distortion.p1 = 0.001;
  camera.distortion.p2 = -0.0005;
  camera.pose.transform.parent_frame = "world";
  camera.pose.transform.child_frame = "camera:" + id;
  return camera;
}

inline formats::CameraDescription TestSensor() {
  formats::CameraDescription sensor;
  sensor.bit_depth = 12;
  sensor.full_well_electrons = 20000;
  sensor.read_noise_electrons = 5;
  return sensor;
}

// world <- board: the board's centre at `centre` (world), turned by `tilt`
// about the world's x and y axes and `spin` about its normal.
inline core::RigidTransform BoardPose(const calibration::CalibrationBoard &board, const Eigen::Vector3d &centre,
                                      double tilt_x_rad, double tilt_y_rad, double spin_rad) {
  const Eigen::Vector2d middle = 0.5 * (board.PrintedMin() + board.PrintedMax());
  const Eigen::Matrix3d rotation =
      (Eigen::AngleAxisd(tilt_x_rad, Eigen::Vector3d::UnitX()) *
       Eigen::AngleAxisd(tilt_y_rad, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(spin_rad, Eigen::Vector3d::UnitZ()))
          .toRotationMatrix();
  core::RigidTransform pose;
  pose.parent_frame = "world";
  pose.child_frame = "board";
  pose.rotation = rotation;
  pose.translation = centre - rotation * Eigen::Vector3d(middle.x(), middle.y(), 0);
  return pose;
}

// `count` poses about `distance_mm` in front of the world origin along +z,
// spread across the view (+-`spread` of the distance sideways, so boards
// reach the image's corners where distortion shows) and tilted up to
// `max_tilt_rad` (seeded).
inline std::vector<core::RigidTransform> BoardPoses(const calibration::CalibrationBoard &board, int count,
                                                    double distance_mm, double max_tilt_rad, std::uint64_t seed,
                                                    double spread = 0.25) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<core::RigidTransform> poses;
  for (int i = 0; i < count; ++i) {
    const Eigen::Vector3d centre(spread * distance_mm * unit(rng), 0.75 * spread * distance_mm * unit(rng),
                                 distance_mm * (1 + 0.15 * unit(rng)));
    poses.push_back(BoardPose(board, centre, max_tilt_rad * unit(rng), max_tilt_rad * unit(rng), 0.3 * unit(rng)));
  }
  return poses;
}

inline core::Image BoardPhoto(const calibration::BoardPrint &print, const core::RigidTransform &world_from_board,
                              const formats::CameraCalibration &camera, std::uint64_t seed,
                              const sim::BoardPhotoOptions &options = {}) {
  const core::Image signal = sim::RenderBoardPhoto(print, world_from_board, camera, options);
  std::mt19937_64 rng(seed);
  return sim::ApplySensor(signal, TestSensor(), rng, true);
}

// Detected corners against their true positions: the detector's own error.
struct DetectorError {
  double rms_px = 0;
  int corners = 0;
};

inline DetectorError Compare(const calibration::BoardDetection &detection, const std::vector<Eigen::Vector2d> &truth) {
  DetectorError error;
  double sum = 0;
  for (std::size_t i = 0; i < detection.size(); ++i) {
    sum += (detection.pixels[i] - truth[static_cast<std::size_t>(detection.ids[i])]).squaredNorm();
    ++error.corners;
  }
  error.rms_px = std::sqrt(sum / std::max(1, error.corners));
  return error;
}

// One camera's photos of the board at `poses`, detected as the CLI does;
// `floor`, when given, gets the detector's error against the truth.
inline calibration::CameraViews Photograph(const calibration::BoardPrint &print,
                                           const formats::CameraCalibration &camera,
                                           const std::vector<core::RigidTransform> &poses, std::uint64_t seed,
                                           DetectorError *floor = nullptr) {
  const calibration::BoardCornerDetector detector(print.board());
  calibration::CameraViews views;
  views.id = camera.id;
  views.width = camera.width;
  views.height = camera.height;
  double sum = 0;
  int corners = 0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const core::Image photo = BoardPhoto(print, poses[i], camera, seed + i);
    views.names.push_back("photo" + std::to_string(i) + ".png");
    views.detections.push_back(detector.Detect(photo));
    views.qualities.push_back(detector.Quality(photo, views.detections.back()));
    const DetectorError e = Compare(views.detections.back(), sim::TrueCornerPixels(print.board(), poses[i], camera));
    sum += e.rms_px * e.rms_px * e.corners;
    corners += e.corners;
  }
  if (floor) *floor = {std::sqrt(sum / std::max(1, corners)), corners};
  return views;
}

}  // namespace mesocap::testing
