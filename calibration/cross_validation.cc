#include "calibration/cross_validation.h"

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
                                                                    std::string* why) {
  CameraCalibrationResult halves[2];
  for (std::size_t parity = 0; parity < 2; ++parity) {
    try {
      halves[parity] = CalibrateCameras(board, Half(cameras, parity), options);
    } catch (const core::Error& e) {
      if (why) *why = std::string(parity == 0 ? "first" : "second") + " half: " + e.what();
      return std::nullopt;
    }
  }
  std::vector<CrossValidationDifference> differences;
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    Eigen::Vector2d lo(1e30, 1e30), hi(-1e30, -1e30);
    for (const BoardDetection& d : cameras[c].detections) {
      for (const Eigen::Vector2d& p : d.pixels) {
        lo = lo.cwiseMin(p);
        hi = hi.cwiseMax(p);
      }
    }
    const CalibratedCamera& a = halves[0].cameras[c];
    const CalibratedCamera& b = halves[1].cameras[c];
    const double depth = a.working_distance_mm;
    CrossValidationDifference difference;
    difference.camera_id = cameras[c].id;
    double sum = 0;
    constexpr int kGrid = 10;
    for (int j = 0; j < kGrid; ++j) {
      for (int i = 0; i < kGrid; ++i) {
        const Eigen::Vector2d pixel = lo + Eigen::Vector2d((hi.x() - lo.x()) * i / (kGrid - 1),
                                                           (hi.y() - lo.y()) * j / (kGrid - 1));
        const Eigen::Vector2d moved = ProjectInCamera(b.calibration, UnprojectAtDepth(a.calibration, pixel, depth));
        const double d = (moved - pixel).norm();
        sum += d * d;
        difference.max_px = std::max(difference.max_px, d);
      }
    }
    difference.rms_px = std::sqrt(sum / (kGrid * kGrid));
    difference.rms_mm = difference.rms_px * depth / a.calibration.intrinsics.fx;
    differences.push_back(difference);
  }
  return differences;
}

}  // namespace mesocap::calibration
