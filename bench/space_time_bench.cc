// Streaming space-time analysis throughput: pixel-frames per
// second per core on 1024x768 frames (the paper's cameras), against a plain
// copy of the same frames measured in the same run. Frames hold a Gaussian
// stripe sweeping across the image once in 64 frames, kept in memory so
// neither side measures I/O, through one of two sensors: the paper rig's
// camera (sim/camera_sensor.h: shot and read noise, 12-bit codes; dark
// pixels stay at a few codes) or a heavy continuous noise of 0.005 of full
// scale, whose dark pixels keep setting new maxima early in a sweep (the
// analyzer's slow path). The analyzer starts afresh every 64 frames, so
// every sweep pays for its rising edges. Also the per-frame laser line
// detection (Gaussian pre-filter + scanline peaks + robust fit) on the
// reference region, which runs once per frame beside the analyzer.
#include <benchmark/benchmark.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#include "calibration/camera_rays.h"
#include "calibration/laser_line.h"
#include "core/image.h"
#include "formats/calibration.h"
#include "mdf/space_time_analyzer.h"
#include "sim/camera_sensor.h"
#include "sim/shipped_rigs.h"

namespace {

constexpr int kWidth = 1024, kHeight = 768, kFrames = 64;

enum Sensor { kPaperCamera = 0, kHeavyNoise = 1 };

std::vector<mesocap::core::Image> StripeFrames(Sensor sensor) {
  const auto camera = mesocap::sim::LoadRig("paper").cameras[0];
  std::mt19937_64 rng(3);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  std::vector<mesocap::core::Image> frames;
  for (int f = 0; f < kFrames; ++f) {
    mesocap::core::Image frame(kWidth, kHeight, 1);
    const double centre = (f + 0.5) * kWidth / kFrames;
    for (int y = 0; y < kHeight; ++y) {
      for (int x = 0; x < kWidth; ++x) {
        const double d = x + 0.1 * y - centre;
        frame.at(x, y) = static_cast<float>(0.8 * std::exp(-d * d / 50.0));
      }
    }
    if (sensor == kPaperCamera) {
      frame = mesocap::sim::ApplySensor(frame, camera, rng, true);
    } else {
      for (std::size_t i = 0; i < frame.size(); ++i) frame.data()[i] += noise(rng);
    }
    frames.push_back(std::move(frame));
  }
  return frames;
}

// Each sensor's frames are made on first use only.
const std::vector<mesocap::core::Image>& Frames(Sensor sensor = kPaperCamera) {
  if (sensor == kPaperCamera) {
    static const std::vector<mesocap::core::Image> paper = StripeFrames(kPaperCamera);
    return paper;
  }
  static const std::vector<mesocap::core::Image> heavy = StripeFrames(kHeavyNoise);
  return heavy;
}

void PlainCopy(benchmark::State& state) {
  const auto& frames = Frames();
  mesocap::core::Image out(kWidth, kHeight, 1);
  int f = 0;
  for (auto _ : state) {
    std::memcpy(out.data(), frames[f].data(), frames[f].size() * sizeof(float));
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
    f = (f + 1) % kFrames;
  }
  state.SetItemsProcessed(state.iterations() * kWidth * kHeight);
}
BENCHMARK(PlainCopy)->Unit(benchmark::kMillisecond);

void SpaceTimeAddFrame(benchmark::State& state) {
  const auto& frames = Frames(static_cast<Sensor>(state.range(0)));
  std::unique_ptr<mesocap::mdf::SpaceTimeAnalyzer> analyzer;
  int index = kFrames;
  for (auto _ : state) {
    if (index == kFrames) {  // a new sweep: its setup is not timed
      state.PauseTiming();
      analyzer = std::make_unique<mesocap::mdf::SpaceTimeAnalyzer>(kWidth, kHeight, kFrames);
      index = 0;
      state.ResumeTiming();
    }
    analyzer->AddFrame(index, frames[index]);
    ++index;
  }
  state.SetItemsProcessed(state.iterations() * kWidth * kHeight);
  state.SetLabel(state.range(0) == kPaperCamera ? "paper camera" : "heavy noise");
}
BENCHMARK(SpaceTimeAddFrame)->Arg(kPaperCamera)->Arg(kHeavyNoise)->Unit(benchmark::kMillisecond);

void SpaceTimeResult(benchmark::State& state) {
  const auto& frames = Frames();
  mesocap::mdf::SpaceTimeAnalyzer analyzer(kWidth, kHeight, kFrames);
  for (int f = 0; f < kFrames; ++f) analyzer.AddFrame(f, frames[f]);
  for (auto _ : state) benchmark::DoNotOptimize(analyzer.Result());
  state.SetItemsProcessed(state.iterations() * kWidth * kHeight);
}
BENCHMARK(SpaceTimeResult)->Unit(benchmark::kMillisecond);

void LaserLineDetection(benchmark::State& state) {
  mesocap::formats::CameraCalibration camera;
  camera.id = "bench";
  camera.width = kWidth;
  camera.height = kHeight;
  camera.intrinsics = {2000, 2000, kWidth / 2.0, kHeight / 2.0, {}};
  camera.pose.transform.rotation << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // looking straight down
  camera.pose.transform.translation = {0, 0, 400};
  const mesocap::calibration::CameraRays rays(camera);
  // The reference region: the outer quarter on each side.
  mesocap::calibration::PixelMask mask(static_cast<std::size_t>(kWidth) * kHeight, 0);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) mask[y * kWidth + x] = (y < kHeight / 4 || y >= 3 * kHeight / 4) ? 1 : 0;
  }
  const auto& frames = Frames();
  int f = 0, found = 0;
  for (auto _ : state) {
    found += mesocap::calibration::DetectLaserLine(frames[f], mask, rays, 0.0, {1, 0}, {}).valid;
    f = (f + 1) % kFrames;
  }
  state.SetItemsProcessed(state.iterations() * kWidth * kHeight);
  state.counters["found"] = static_cast<double>(found) / state.iterations();
}
BENCHMARK(LaserLineDetection)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
