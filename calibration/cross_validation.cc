#include "calibration/cross_validation.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

namespace mesocap::calibration {
namespace {

// The views of the instants with the given parity; the others emptied.
std::vector<CameraViews> Half(const std::vector<CameraViews>& cameras, std::size_t parity) {
  std::vector<CameraViews> half = cameras;
  for (CameraViews& views : half) {
    std::size_t seen = 0;
    for (std::size_t i = 0; i < views.detections.size(); ++i) {
      // Alternate among the instants any camera saw the board at, so both
      // halves get photos from the whole session.
      bool any = false;
      for (const CameraViews& c : cameras) any = any || !c.detections[i].empty();
      if (!any) continue;
      if (seen++ % 2 != parity) views.detections[i] = {};
    }
  }
  return half;
}

}  // namespace

std::optional<std::vector<CrossValidationDifference>> CrossValidate(const CalibrationBoard& board,
                                                                    const std::vector<CameraViews>& cameras,
                                                                    const CameraCalibrationOptions& options,
                                                                    const CameraCalibrationResult& calibrated,
                                                                    std::string* why, const TurntableMotion* motion) {
  CameraCalibrationOptions fixed = options;
  fixed.distortion_models = ChosenDistortionModels(calibrated);
  CameraCalibrationResult halves[2];
  for (std::size_t parity = 0; parity < 2; ++parity) {
    try {
      halves[parity] = CalibrateCameras(board, Half(cameras, parity), fixed, motion);
    } catch (const core::Error& e) {
      if (why) *why = std::string(parity == 0 ? "first" : "second") + " half: " + e.what();
      return std::nullopt;
    }
  }
  std::vector<CrossValidationDifference> differences;
  constexpr int kGrid = 10;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    const formats::CameraCalibration& a = halves[0].cameras[c].calibration;
    const formats::CameraCalibration& b = halves[1].cameras[c].calibration;
    CrossValidationDifference difference;
    difference.camera_id = cameras[c].id;
    double sum = 0, depth_sum = 0;
    const auto add = [&](const Eigen::Vector2d& pa, const Eigen::Vector2d& pb, double depth) {
      const double d = (pa - pb).norm();
      sum += d * d;
      depth_sum += depth;
      difference.max_px = std::max(difference.max_px, d);
    };
    if (motion) {
      // The sample square on the reference plane, through each half's
      // camera: world <- camera poses.
      for (int j = 0; j < kGrid; ++j) {
        for (int i = 0; i < kGrid; ++i) {
          const Eigen::Vector3d world(motion->sample_size_mm * (i / (kGrid - 1.0) - 0.5),
                                      motion->sample_size_mm * (j / (kGrid - 1.0) - 0.5), 0.0);
          const auto in = [&](const formats::CameraCalibration& cam) {
            return Eigen::Vector3d(cam.pose.transform.rotation.transpose() * (world - cam.pose.transform.translation));
          };
          add(ProjectInCamera(a, in(a)), ProjectInCamera(b, in(b)), in(a).z());
        }
      }
    } else {
      Eigen::Vector2d lo(1e30, 1e30), hi(-1e30, -1e30);
      for (const BoardDetection& d : cameras[c].detections) {
        for (const Eigen::Vector2d& p : d.pixels) {
          lo = lo.cwiseMin(p);
          hi = hi.cwiseMax(p);
        }
      }
      const double depth = halves[0].cameras[c].working_distance_mm;
      std::vector<Eigen::Vector2d> pixels;
      Eigen::Matrix3Xd rays_a(3, kGrid * kGrid), rays_b(3, kGrid * kGrid);
      for (int j = 0; j < kGrid; ++j) {
        for (int i = 0; i < kGrid; ++i) {
          pixels.push_back(lo +
                           Eigen::Vector2d((hi.x() - lo.x()) * i / (kGrid - 1), (hi.y() - lo.y()) * j / (kGrid - 1)));
          rays_a.col(static_cast<int>(pixels.size()) - 1) = UnprojectAtDepth(a, pixels.back(), 1.0).normalized();
          rays_b.col(static_cast<int>(pixels.size()) - 1) = UnprojectAtDepth(b, pixels.back(), 1.0).normalized();
        }
      }
      // The rotation taking one half's rays onto the other's (Kabsch, by
      // Eigen's SVD of their correlation).
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(rays_b * rays_a.transpose(),
                                                  Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d turn = svd.matrixU() * svd.matrixV().transpose();
      if (turn.determinant() < 0) {
        Eigen::Matrix3d flip = Eigen::Matrix3d::Identity();
        flip(2, 2) = -1;
        turn = svd.matrixU() * flip * svd.matrixV().transpose();
      }
      for (std::size_t n = 0; n < pixels.size(); ++n) {
        add(pixels[n], ProjectInCamera(b, turn * rays_a.col(static_cast<int>(n)) * depth), depth);
      }
    }
    difference.rms_px = std::sqrt(sum / (kGrid * kGrid));
    difference.rms_mm = difference.rms_px * (depth_sum / (kGrid * kGrid)) / a.intrinsics.fx;
    differences.push_back(difference);
  }
  return differences;
}

}  // namespace mesocap::calibration
