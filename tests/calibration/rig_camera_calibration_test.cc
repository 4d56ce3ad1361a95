// A rig's cameras and turntable calibrated from photos of a board on a
// holder on the turntable, against the simulated rig's exact calibration
// (sim/true_calibration.h).
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "calibration/camera_calibration.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"
#include "tests/common/board_photos.h"

namespace mesocap::calibration {
namespace {

struct RigPhotos {
  std::vector<CameraViews> views;
  TurntableMotion motion;
  std::vector<core::RigidTransform> holders;  // turntable <- board, the truth
};

RigPhotos Photograph(const formats::Calibration& truth, const CalibrationBoard& board,
                     const std::vector<double>& tilts_deg, int angles, double height, std::uint64_t seed) {
  const BoardPrint print(board);
  const BoardCornerDetector detector(board);
  RigPhotos photos;
  photos.motion.board_height_mm = height;
  for (const auto& camera : truth.cameras) {
    CameraViews v;
    v.id = camera.id;
    v.width = camera.width;
    v.height = camera.height;
    photos.views.push_back(v);
  }
  for (std::size_t h = 0; h < tilts_deg.size(); ++h) {
    photos.holders.push_back(sim::BoardOnHolder(board, height, tilts_deg[h] * 3.14159265358979 / 180));
    for (int a = 0; a < angles; ++a) {
      const double angle = 2 * 3.14159265358979 * a / angles;
      core::RigidTransform turn;
      turn.parent_frame = "world";
      turn.child_frame = "turntable";
      turn.rotation = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const core::RigidTransform world_from_board = turn.Compose(photos.holders.back());
      photos.motion.holder.push_back(static_cast<int>(h));
      photos.motion.angle_rad.push_back(angle);
      for (std::size_t c = 0; c < truth.cameras.size(); ++c) {
        const core::Image photo = testing::BoardPhoto(print, world_from_board, truth.cameras[c], seed++);
        CameraViews& v = photos.views[c];
        v.names.push_back("h" + std::to_string(h) + "_a" + std::to_string(a));
        v.detections.push_back(detector.Detect(photo));
        v.qualities.push_back(detector.Quality(photo, v.detections.back()));
      }
    }
  }
  return photos;
}

TEST(RigCameraCalibration, SmallRigCamerasInTheTurntablesFrame) {
  const formats::Calibration truth = sim::TrueCalibration(sim::LoadRig("small"));
  const CalibrationBoard board = ParseBoardSpec("charuco:7x5:4:3:DICT_4X4_50");
  const RigPhotos photos = Photograph(truth, board, {0, 35, -35}, 12, 2.0, 1);
  const CameraCalibrationResult result = CalibrateCameras(board, photos.views, {}, &photos.motion);
  for (std::size_t c = 0; c < truth.cameras.size(); ++c) {
    const formats::CameraCalibration& t = truth.cameras[c];
    const formats::CameraCalibration& e = result.cameras[c].calibration;
    const Eigen::Vector3d centre_error = e.pose.transform.translation - t.pose.transform.translation;
    const double angle_error =
        Eigen::AngleAxisd(e.pose.transform.rotation * t.pose.transform.rotation.transpose()).angle() * 180 / 3.14159265;
    std::printf("%s used %d rms %.3f fx %.2f+-%.2f (truth %.2f) cx %.2f+-%.2f centre err %.4f %.4f %.4f (std %.4f %.4f %.4f) rot err %.4f deg\n",
                e.id.c_str(), result.cameras[c].images_used, result.cameras[c].rms_px, e.intrinsics.fx,
                *e.intrinsics.uncertainty.fx, t.intrinsics.fx, e.intrinsics.cx, *e.intrinsics.uncertainty.cx,
                centre_error.x(), centre_error.y(), centre_error.z(), (*e.pose.uncertainty.translation_mm).x(),
                (*e.pose.uncertainty.translation_mm).y(), (*e.pose.uncertainty.translation_mm).z(), angle_error);
  }
  for (const auto& w : result.warnings) std::printf("warning: %s\n", w.c_str());
}

}  // namespace
}  // namespace mesocap::calibration
