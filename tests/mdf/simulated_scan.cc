#include "tests/mdf/simulated_scan.h"

#include <chrono>
#include <cmath>

#include "calibration/nominal_geometry.h"
#include "formats/capture_plan_steps.h"
#include "formats/rig_description.h"
#include "mdf/laser_sweep.h"
#include "mdf/mdf_assembler.h"
#include "mdf/session_sweeps.h"
#include "sim/camera_renderer.h"
#include "sim/camera_sensor.h"
#include "sim/ground_truth.h"
#include "sim/laser_sweep_renderer.h"
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
  gt.texels.width = gt.texels.height = setup.texture_size;
  gt.texels.sample_size_mm = rig.sample_size_mm;
  gt.views = views;
  ScanResult result;
  result.truth = sim::ComputeTrueMdf(*scene, gt);

  calibration::TexelGrid grid{setup.texture_size, setup.texture_size, rig.sample_size_mm};
  result.texel_mm = grid.texel_width_mm();
  TriangulationOptions triangulation = setup.triangulation;
  triangulation.backing_depth_mm = rig.backing.depth_mm;
  MdfAssembler assembler(grid, views, triangulation, setup.merge);
  auto sense = [&](core::Image signal, int cam, std::uint64_t a, std::uint64_t b, std::uint64_t c) {
    if (setup.signal_gain != 1.0) {
      for (std::size_t i = 0; i < signal.size(); ++i) signal.data()[i] *= static_cast<float>(setup.signal_gain);
    }
    std::mt19937_64 rng = sim::ImageNoiseGenerator(7, {a, b, c});
    return sim::ApplySensor(signal, rig.cameras[cam], rng, setup.noise);
  };

  const std::vector<int> cameras = AllOr(setup.cameras, static_cast<int>(rig.cameras.size()));
  const std::vector<int> locations = AllOr(setup.locations, static_cast<int>(laser.locations.size()));
  // The plan's laser-plane calibration (Sec. 3.2): two plates per location,
  // rendered when the geometry first needs a location's plane for a camera.
  std::vector<formats::LaserCalibrationStep> plates;
  for (std::size_t li = 0; li < laser.locations.size(); ++li) {
    for (int hi = 0; hi < 2; ++hi) {
      formats::LaserCalibrationStep plate;
      plate.location = static_cast<int>(li);
      plate.mount = laser.locations[li].mount;
      plate.arc_rad = laser.locations[li].arc_angle_rad;
      plate.height_mm = laser.calibration_heights_mm[hi];
      plates.push_back(plate);
    }
  }
  const auto plate_frame = [&](int li, int hi, int cam) {
    const auto& loc = laser.locations[li];
    const sim::CameraView plate = renderer.TracePlate(cam, laser.calibration_heights_mm[hi]);
    return sense(sim::LaserSweepRenderer(renderer, plate, loc.mount, loc.arc_angle_rad).Frame(0.0), cam, 1000 + li, cam,
                 hi);
  };
  SweepGeometryOptions geometry_options;
  geometry_options.line = setup.line;
  SessionSweepGeometry geometry(rig, calibration, std::move(plates), plate_frame, geometry_options);

  std::vector<bool> processed(views.size(), false);
  for (int ti : AllOr(setup.turntable_indices, static_cast<int>(rig.turntable.angles_rad.size()))) {
    // The plan's sweeps at this turntable angle, their poses computed once.
    std::vector<formats::LaserSweepStep> sweeps;
    std::vector<SweepPoses> poses;
    for (int li : locations) {
      formats::LaserSweepStep step;
      step.turntable_index = ti;
      step.turntable_rad = rig.turntable.angles_rad[ti];
      step.location = li;
      step.mount = laser.locations[li].mount;
      step.arc_rad = laser.locations[li].arc_angle_rad;
      for (int f = 0; f < laser.frames_per_sweep; ++f) {
        const double offset =
            laser.sweep_min_mm + (laser.sweep_max_mm - laser.sweep_min_mm) * f / (laser.frames_per_sweep - 1);
        step.offsets_mm.push_back(offset);
        step.tilts_rad.push_back(calibration::LaserTiltForOffset(laser, step.mount, offset));
      }
      poses.push_back(geometry.Poses(step));
      sweeps.push_back(std::move(step));
    }
    for (int cam : cameras) {
      const sim::CameraView view = renderer.TraceSample(cam, rig.turntable.angles_rad[ti]);
      const int view_index = geometry.View(views, poses.front(), cam);
      processed[view_index] = true;
      for (std::size_t s = 0; s < sweeps.size(); ++s) {
        const formats::LaserSweepStep& step = sweeps[s];
        LaserSweepProcessor processor(geometry.rays(cam), geometry.Geometry(step, poses[s], cam), setup.line,
                                      setup.space_time);
        const sim::LaserSweepRenderer sweep(renderer, view, step.mount, step.arc_rad);
        for (int f = 0; f < laser.frames_per_sweep; ++f) {
          if (setup.dropped_frames.count(f)) continue;
          core::Image signal = sweep.Frame(step.tilts_rad[f]);
          if (setup.tamper) setup.tamper(f, &signal);
          const core::Image frame = sense(std::move(signal), cam, ti * 100 + step.location, cam, f);
          const auto start = Clock::now();
          processor.AddFrame(f, frame);
          result.processing_seconds += Seconds(Clock::now() - start);
        }
        const auto start = Clock::now();
        geometry.AddToMdf(assembler, view_index, step, poses[s], cam, processor.Finish());
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
