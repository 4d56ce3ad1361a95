#include "tests/mdf/simulated_scan.h"

#include <chrono>
#include <cmath>

#include "calibration/camera_rays.h"
#include "calibration/laser_plane_calibration.h"
#include "calibration/nominal_geometry.h"
#include "calibration/rig_frames.h"
#include "core/plane.h"
#include "formats/rig_description.h"
#include "mdf/laser_sweep.h"
#include "mdf/mdf_assembler.h"
#include "sim/camera_renderer.h"
#include "sim/camera_sensor.h"
#include "sim/ground_truth.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"

namespace mesocap::mdf {
namespace {

using Clock = std::chrono::steady_clock;
double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

std::vector<int> AllOr(const std::vector<int>& chosen, int count) {
  if (!chosen.empty()) return chosen;
  std::vector<int> all(count);
  for (int i = 0; i < count; ++i) all[i] = i;
  return all;
}

}  // namespace

ScanResult RunSimulatedScan(const ScanSetup& setup) {
  const auto scene = sim::MakeBuiltinScene(setup.scene);
  const formats::RigDescription rig = sim::LoadRig(setup.rig);
  const formats::Calibration calibration = sim::TrueCalibration(rig);
  const sim::CameraRenderer renderer(*scene, rig);
  const core::SamplingSet views = calibration::ViewDirections(rig);
  const auto& laser = rig.laser;

  sim::GroundTruthOptions gt;
  gt.texture_width = gt.texture_height = setup.texture_size;
  gt.sample_size_mm = rig.sample_size_mm;
  gt.views = views;
  ScanResult result;
  result.truth = sim::ComputeTrueMdf(*scene, gt);

  calibration::TexelGrid grid{setup.texture_size, setup.texture_size, rig.sample_size_mm};
  result.texel_mm = grid.texel_width_mm();
  TriangulationOptions triangulation = setup.triangulation;
  triangulation.backing_depth_mm = rig.backing.depth_mm;
  MdfAssembler assembler(grid, views, triangulation, setup.merge);
  const double outer_mm = 1.5 * rig.sample_size_mm;
  auto sense = [&](core::Image signal, int cam, std::uint64_t a, std::uint64_t b, std::uint64_t c) {
    if (setup.signal_gain != 1.0) {
      for (std::size_t i = 0; i < signal.size(); ++i) signal.data()[i] *= static_cast<float>(setup.signal_gain);
    }
    std::mt19937_64 rng = sim::ImageNoiseGenerator(7, {a, b, c});
    return sim::ApplySensor(signal, rig.cameras[cam], rng, setup.noise);
  };

  const std::vector<int> cameras = AllOr(setup.cameras, static_cast<int>(rig.cameras.size()));
  const std::vector<int> locations = AllOr(setup.locations, static_cast<int>(laser.locations.size()));
  std::vector<calibration::CameraRays> rays;
  for (const auto& camera : calibration.cameras) rays.emplace_back(camera);
  // Laser-plane calibration per location and camera (Sec. 3.2).
  std::vector<std::vector<core::Plane>> calibrated(laser.locations.size(), std::vector<core::Plane>(rig.cameras.size()));
  for (int li : locations) {
    const auto& loc = laser.locations[li];
    const calibration::LaserMountPose pose = calibration::MountInWorld(calibration, loc.mount, loc.arc_angle_rad, 0.0);
    for (int cam : cameras) {
      core::Image plates[2];
      for (int hi = 0; hi < 2; ++hi) {
        const sim::CameraView plate = renderer.TracePlate(cam, laser.calibration_heights_mm[hi]);
        plates[hi] = sense(sim::LaserSweepRenderer(renderer, plate, loc.mount, loc.arc_angle_rad).Frame(0.0), cam,
                           1000 + li, cam, hi);
      }
      calibrated[li][cam] = calibration::CalibrateLaserPlane(plates[0], laser.calibration_heights_mm[0], plates[1],
                                                laser.calibration_heights_mm[1], rays[cam],
                                                pose.normal.head<2>().normalized(), outer_mm, setup.line, "test");
    }
  }
  std::vector<bool> processed(views.size(), false);
  for (int ti : AllOr(setup.turntable_indices, static_cast<int>(rig.turntable.angles_rad.size()))) {
    const double tt = rig.turntable.angles_rad[ti];
    const core::RigidTransform world_from_sample = calibration::WorldFromSample(calibration.turntable, tt);
    for (int cam : cameras) {
      const sim::CameraView view = renderer.TraceSample(cam, tt);
      const Eigen::Vector3d to_camera =
          world_from_sample.Inverse().rotation * (rays[cam].centre() - world_from_sample.translation);
      const int view_index = views.Nearest(to_camera.normalized());
      processed[view_index] = true;
      const calibration::PixelMask region = ReferenceRegion(rays[cam], world_from_sample, rig.sample_size_mm, 1.0, outer_mm);
      for (int li : locations) {
        const auto& loc = laser.locations[li];
        const calibration::LaserMountPose pose = calibration::MountInWorld(calibration, loc.mount, loc.arc_angle_rad, 0.0);
        SweepGeometry geometry;
        geometry.reference_region = region;
        geometry.calibrated_plane = calibrated[li][cam];
        geometry.tilt_axis = pose.tilt_axis;
        std::vector<double> tilts;
        for (int f = 0; f < laser.frames_per_sweep; ++f) {
          const double offset =
              laser.sweep_min_mm + (laser.sweep_max_mm - laser.sweep_min_mm) * f / (laser.frames_per_sweep - 1);
          tilts.push_back(calibration::LaserTiltForOffset(laser, loc.mount, offset));
        }
        geometry.delta_tilt_rad = tilts;
        LaserSweepProcessor processor(rays[cam], geometry, setup.line, setup.space_time);
        const sim::LaserSweepRenderer sweep(renderer, view, loc.mount, loc.arc_angle_rad);
        for (int f = 0; f < laser.frames_per_sweep; ++f) {
          if (setup.dropped_frames.count(f)) continue;
          core::Image signal = sweep.Frame(tilts[f]);
          if (setup.tamper) setup.tamper(f, &signal);
          const core::Image frame = sense(std::move(signal), cam, ti * 100 + li, cam, f);
          const auto start = Clock::now();
          processor.AddFrame(f, frame);
          result.processing_seconds += Seconds(Clock::now() - start);
        }
        const auto start = Clock::now();
        const double weight = ScanWeight(pose.source, rays[cam].centre(), calibrated[li][cam], 0.5 * rig.sample_size_mm);
        assembler.AddSweep(view_index, processor.Finish(), rays[cam], world_from_sample, weight);
        result.processing_seconds += Seconds(Clock::now() - start);
      }
    }
  }
  const auto start = Clock::now();
  result.estimate = assembler.Finish(&result.confidence);
  result.processing_seconds += Seconds(Clock::now() - start);
  // Views not scanned are left out of the comparison (unknown in the truth).
  for (int v = 0; v < views.size(); ++v) {
    if (processed[v]) continue;
    for (int j = 0; j < result.truth.height; ++j) {
      for (int i = 0; i < result.truth.width; ++i) result.truth.at(i, j, v) = core::MdfUnknown();
    }
  }
  return result;
}

}  // namespace mesocap::mdf
