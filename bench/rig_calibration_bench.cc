// A rig's calibration from its board photos (calibration/camera_calibration.h
// with the turntable): time of the solve (Zhang's start, robust and final
// Ceres solves, covariance) against the error of the result, as the number
// of turntable angles and holder tilts grows, on the small and paper rigs.
// The photos are rendered as the simulated rig's calibration session renders
// them (sim/board_photo_renderer.h, the rig's calibration_board) and
// detected once, outside the timing. Errors against the simulator's truth:
// the sample square's image (what processing uses), focal lengths, camera
// centres; beside them the calibration's own sigma for the sample centre.
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <map>
#include <numbers>

#include "calibration/board_corner_detector.h"
#include "calibration/camera_calibration.h"
#include "sim/board_photo_renderer.h"
#include "sim/camera_sensor.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"

namespace mesocap {
namespace {

struct Photos {
  formats::Calibration truth;
  calibration::CalibrationBoard board;
  std::vector<calibration::CameraViews> views;
  calibration::TurntableMotion motion;
};

// `angles` turntable angles evenly over the turn; the rig's first `tilts`
// holder tilts.
Photos Photograph(const std::string& rig_name, int angles, int tilts) {
  const formats::RigDescription rig = sim::LoadRig(rig_name);
  Photos p;
  p.truth = sim::TrueCalibration(rig);
  p.board = *calibration::RigCalibrationBoard(rig);
  const calibration::BoardPrint print(p.board);
  const calibration::BoardCornerDetector detector(p.board);
  p.motion.board_height_mm = rig.calibration_board->height_mm;
  p.motion.sample_size_mm = rig.sample_size_mm;
  for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
    calibration::CameraViews v;
    v.id = rig.cameras[c].id;
    v.width = rig.cameras[c].width;
    v.height = rig.cameras[c].height;
    p.views.push_back(v);
  }
  std::uint64_t seed = 1;
  for (int h = 0; h < tilts; ++h) {
    const core::RigidTransform holder =
        sim::BoardOnHolder(p.board, rig.calibration_board->height_mm, rig.calibration_board->holder_tilts_rad.at(h));
    for (int a = 0; a < angles; ++a) {
      const double angle = 2 * std::numbers::pi * a / angles;
      core::RigidTransform turn;
      turn.parent_frame = "world";
      turn.child_frame = "turntable";
      turn.rotation = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      const core::RigidTransform world_from_board = turn.Compose(holder);
      p.motion.holder.push_back(h);
      p.motion.angle_rad.push_back(angle);
      for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
        sim::BoardPhotoOptions options;
        options.samples_per_pixel_side = 3;
        std::mt19937_64 rng(seed++);
        const core::Image photo = sim::ApplySensor(
            sim::RenderBoardPhoto(print, world_from_board, p.truth.cameras[c], options), rig.cameras[c], rng, true);
        calibration::CameraViews& v = p.views[c];
        v.names.push_back("h" + std::to_string(h) + "_a" + std::to_string(a));
        v.detections.push_back(detector.Detect(photo));
        v.qualities.push_back(detector.Quality(photo, v.detections.back()));
      }
    }
  }
  return p;
}

const Photos& Cached(const std::string& rig, int angles, int tilts) {
  static std::map<std::tuple<std::string, int, int>, Photos> cache;
  const auto key = std::make_tuple(rig, angles, tilts);
  if (!cache.count(key)) cache[key] = Photograph(rig, angles, tilts);
  return cache.at(key);
}

void RigCalibration(benchmark::State& state, const std::string& rig) {
  const Photos& p = Cached(rig, static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  calibration::CameraCalibrationResult result;
  for (auto _ : state) {
    try {
      result = calibration::CalibrateCameras(p.board, p.views, {}, &p.motion);
    } catch (const core::Error& e) {
      state.SkipWithError(e.what());
      return;
    }
  }
  double sample_px = 0, focal = 0, centre = 0, sigma = 0;
  int photos = 0;
  for (std::size_t c = 0; c < p.truth.cameras.size(); ++c) {
    const formats::CameraCalibration& t = p.truth.cameras[c];
    const formats::CameraCalibration& e = result.cameras[c].calibration;
    for (const Eigen::Vector3d& x : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(8, 8, 0), Eigen::Vector3d(-8, 8, 0),
                                     Eigen::Vector3d(8, -8, 0), Eigen::Vector3d(-8, -8, 0)}) {
      const auto image = [&](const formats::CameraCalibration& cam) {
        return calibration::ProjectInCamera(
            cam, cam.pose.transform.rotation.transpose() * (x - cam.pose.transform.translation));
      };
      sample_px = std::max(sample_px, (image(e) - image(t)).norm());
    }
    focal = std::max(focal, std::abs(e.intrinsics.fx / t.intrinsics.fx - 1));
    centre = std::max(centre, (e.pose.transform.translation - t.pose.transform.translation).norm());
    sigma = std::max(sigma, result.cameras[c].projection_uncertainty_px);
    photos += result.cameras[c].images_used;
  }
  state.counters["photos_used"] = photos;
  state.counters["sample_err_px_max"] = sample_px;
  state.counters["sample_sigma_px_max"] = sigma;
  state.counters["focal_err_pct_max"] = 100 * focal;
  state.counters["centre_err_mm_max"] = centre;
  state.counters["rms_px"] = result.residual_sigma_px;
}

// (turntable angles, holder tilts)
BENCHMARK_CAPTURE(RigCalibration, small, std::string("small"))
    ->Args({4, 3})
    ->Args({6, 3})
    ->Args({6, 5})
    ->Args({12, 3})
    ->Args({12, 5})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);
BENCHMARK_CAPTURE(RigCalibration, paper, std::string("paper"))
    ->Args({4, 3})
    ->Args({12, 5})
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace mesocap

BENCHMARK_MAIN();
