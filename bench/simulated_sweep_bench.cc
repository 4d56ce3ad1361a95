// What one laser-sweep frame of the `paper` rig costs the simulated rig
// (the paper-session simulate time is mostly its 958,464 sweep frames): the
// stripe's signal (LaserSweepRenderer::Frame, at
// 1 and 3 x 3 rays per pixel), the sensor (shot and read noise, 12-bit
// codes) on the camera's RGB frame, and both through CameraRenderer::Render
// as a simulated camera calls it. `weave` on camera 3 (50.6 degrees
// elevation), turntable at 0, laser location 0, tilts across the sweep;
// setup (tracing the view and the sweep's shadow rays) is outside the timing.
#include <benchmark/benchmark.h>

#include <memory>
#include <random>
#include <vector>

#include "calibration/nominal_geometry.h"
#include "formats/rig_description.h"
#include "sim/builtin_scenes.h"
#include "sim/camera_renderer.h"
#include "sim/camera_sensor.h"
#include "sim/laser_sweep_renderer.h"
#include "sim/shipped_rigs.h"

namespace {

using mesocap::sim::CameraRenderer;

constexpr int kCamera = 3;
constexpr int kLocation = 0;

struct SweepSetup {
  mesocap::formats::RigDescription rig = mesocap::sim::LoadRig("paper");
  std::unique_ptr<mesocap::sim::MesostructureScene> scene = mesocap::sim::MakeBuiltinScene("weave");
  std::unique_ptr<mesocap::sim::CameraRenderer> renderer;
  std::unique_ptr<mesocap::sim::LaserSweepRenderer> sweep;
  std::vector<double> tilts;

  explicit SweepSetup(int samples_per_pixel_side) {
    mesocap::sim::CameraRendererOptions options;
    options.samples_per_pixel_side = samples_per_pixel_side;
    renderer = std::make_unique<mesocap::sim::CameraRenderer>(*scene, rig, options);
    const auto& loc = rig.laser.locations[kLocation];
    const auto view = renderer->TraceSample(kCamera, 0.0);
    sweep = std::make_unique<mesocap::sim::LaserSweepRenderer>(*renderer, view, loc.mount, loc.arc_angle_rad);
    for (int f = 0; f < rig.laser.frames_per_sweep; ++f) {
      const double offset = rig.laser.sweep_min_mm +
                            (rig.laser.sweep_max_mm - rig.laser.sweep_min_mm) * f / (rig.laser.frames_per_sweep - 1);
      tilts.push_back(mesocap::calibration::LaserTiltForOffset(rig.laser, loc.mount, offset));
    }
  }
};

const SweepSetup& Setup(int side) {
  static std::unique_ptr<SweepSetup> setups[4];
  if (!setups[side]) setups[side] = std::make_unique<SweepSetup>(side);
  return *setups[side];
}

void StripeFrame(benchmark::State& state) {
  const SweepSetup& s = Setup(static_cast<int>(state.range(0)));
  std::size_t f = 0;
  for (auto _ : state) {
    mesocap::core::Image frame = s.sweep->Frame(s.tilts[f]);
    benchmark::DoNotOptimize(frame.data());
    f = (f + 1) % s.tilts.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(StripeFrame)->Arg(1)->Arg(3)->Unit(benchmark::kMillisecond)->UseRealTime();

// The sensor on a dark RGB frame with one stripe: nearly every value is a
// zero signal, as in a sweep frame.
void SensorOnSweepFrame(benchmark::State& state) {
  const SweepSetup& s = Setup(1);
  const mesocap::core::Image stripe = s.sweep->Frame(s.tilts[s.tilts.size() / 2]);
  mesocap::core::Image rgb(stripe.width(), stripe.height(), 3);
  for (int y = 0; y < stripe.height(); ++y) {
    for (int x = 0; x < stripe.width(); ++x) {
      for (int c = 0; c < 3; ++c) rgb.at(x, y, c) = stripe.at(x, y);
    }
  }
  std::size_t lit = 0;
  for (std::size_t i = 0; i < rgb.size(); ++i) lit += rgb.data()[i] > 0.0f ? 1 : 0;
  state.counters["lit_share"] = static_cast<double>(lit) / static_cast<double>(rgb.size());
  std::mt19937_64 rng(5);
  for (auto _ : state) {
    mesocap::core::Image out = mesocap::sim::ApplySensor(rgb, s.rig.cameras[kCamera], rng, true);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(SensorOnSweepFrame)->Unit(benchmark::kMillisecond)->UseRealTime();

// A sweep frame as the simulated camera makes it: Render (the stripe on an
// RGB frame, or the stripe alone for a mono readout) and the sensor.
void RenderedSweepFrame(benchmark::State& state) {
  const int side = static_cast<int>(state.range(0));
  const int channels = static_cast<int>(state.range(1));  // 3: RGB readout, 1: mono
  const SweepSetup& s = Setup(side);
  mesocap::sim::CameraRendererOptions options;
  options.samples_per_pixel_side = side;
  mesocap::sim::CameraRenderer renderer(*s.scene, s.rig, options);
  mesocap::sim::SimulatedRigState rig_state;
  rig_state.lamps_on.assign(s.rig.lamps.elevations_rad.size(), false);
  rig_state.laser_on = true;
  rig_state.laser_mount = s.rig.laser.locations[kLocation].mount;
  rig_state.light_arc_rad = s.rig.laser.locations[kLocation].arc_angle_rad;
  rig_state.laser_tilt_rad = s.tilts[0];
  renderer.Render(rig_state, kCamera, channels);  // traces the view and the sweep's samples
  std::mt19937_64 rng(5);
  std::size_t f = 0;
  for (auto _ : state) {
    rig_state.laser_tilt_rad = s.tilts[f];
    mesocap::core::Image out =
        mesocap::sim::ApplySensor(renderer.Render(rig_state, kCamera, channels), s.rig.cameras[kCamera], rng, true);
    benchmark::DoNotOptimize(out.data());
    f = (f + 1) % s.tilts.size();
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["frames_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(RenderedSweepFrame)
    ->Args({1, 3})
    ->Args({3, 3})
    ->Args({1, 1})
    ->Args({3, 1})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
