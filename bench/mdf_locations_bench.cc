// MDF error against the number of laser locations and against camera noise
// and resolution: the small
// rig, scene blocks, camera 1 (33.75 degrees), turntable angle 0, default
// sensor noise, 1 to all 8 locations (spread over sides and mounts in the
// order 4 7 1 2 5 0 6 3). Frames are rendered by the simulated rig and fed
// to the streaming code in memory; the reported time is the processing
// alone (line detection, space-time analysis, triangulation, resampling,
// merging), the rendering excluded. Errors in texel widths (0.3125 mm),
// coverage inside the sample pocket (mdf/mdf_evaluation.h).
#include <benchmark/benchmark.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mdf/mdf_evaluation.h"
#include "tests/mdf/simulated_scan.h"

namespace {

// Runs the scan (its processing time is the iteration's time) and reports
// its error up to theta_max_deg as counters.
mesocap::mdf::MdfErrorRow ScanAndReport(benchmark::State& state, const mesocap::mdf::ScanSetup& setup,
                                        double theta_max_deg) {
  mesocap::mdf::ScanResult r;
  for (auto _ : state) {
    r = mesocap::mdf::RunSimulatedScan(setup);
    state.SetIterationTime(r.processing_seconds);
  }
  const auto row = mesocap::mdf::EvaluateMdfViews(r.truth, r.estimate, r.texel_mm, {0, theta_max_deg, true});
  state.counters["median_texels"] = row.median_texels;
  state.counters["p95_texels"] = row.p95_texels;
  state.counters["coverage"] = row.coverage;
  state.counters["processing_s"] = r.processing_seconds;
  return row;
}

void ErrorAgainstLocations(benchmark::State& state) {
  const std::vector<int> order = {4, 7, 1, 2, 5, 0, 6, 3};
  mesocap::mdf::ScanSetup setup;
  setup.scene = "blocks";
  setup.rig = "small";
  setup.turntable_indices = {0};
  setup.cameras = {1};
  setup.locations.assign(order.begin(), order.begin() + state.range(0));
  ScanAndReport(state, setup, 90);
  state.counters["locations"] = static_cast<double>(state.range(0));
}
BENCHMARK(ErrorAgainstLocations)
    ->Arg(1)
    ->Arg(2)
    ->Arg(4)
    ->Arg(8)
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// Error against camera noise and resolution: all 8 locations,
// the same camera; noise off / on (the rig's default: 20000 e- full well,
// 5 e- read noise, 12 bit), and the small rig's cameras at half, full and
// double resolution (image size and focal length scaled together, so the
// field of view is the same and a pixel covers 0.25, 0.125, 0.0625 mm).
void ErrorAgainstNoiseAndResolution(benchmark::State& state) {
  const bool noise = state.range(0) != 0;
  const double scale = state.range(1) / 100.0;
  nlohmann::json rig = nlohmann::json::parse(std::ifstream(std::string(MESOCAP_SOURCE_DIR) + "/sim/rigs/small.json"));
  for (auto& camera : rig["cameras"]) {
    camera["image_size"] = {std::lround(camera["image_size"][0].get<double>() * scale),
                            std::lround(camera["image_size"][1].get<double>() * scale)};
    camera["focal_px"] = camera["focal_px"].get<double>() * scale;
  }
  const auto file = std::filesystem::temp_directory_path() / ("mesocap-bench-rig-" + std::to_string(::getpid()) + "-" +
                                                              std::to_string(state.range(1)) + ".json");
  std::ofstream(file) << rig.dump();
  mesocap::mdf::ScanSetup setup;
  setup.scene = "blocks";
  setup.rig = file.string();
  setup.turntable_indices = {0};
  setup.cameras = {1};
  setup.noise = noise;
  ScanAndReport(state, setup, 90);
  std::filesystem::remove(file);
  state.counters["noise"] = noise;
  // A pixel's footprint on the sample at normal incidence: distance / focal length.
  state.counters["pixel_mm"] =
      rig["cameras"][1]["distance_mm"].get<double>() / rig["cameras"][1]["focal_px"].get<double>();
}
BENCHMARK(ErrorAgainstNoiseAndResolution)
    ->Args({0, 100})
    ->Args({1, 100})
    ->Args({1, 50})
    ->Args({1, 200})
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kMillisecond);

// The MDF acceptance figures on the whole small-rig session: every
// view up to 60 degrees (6 turntable angles x cameras 0-2), all 8
// locations; Arg 0 is blocks, 1 weave. ~2 minutes a scene (18,432 frames
// rendered); the acceptance tests use turntable angle 0 only.
void WholeSessionAcceptance(benchmark::State& state) {
  mesocap::mdf::ScanSetup setup;
  setup.scene = state.range(0) == 0 ? "blocks" : "weave";
  setup.rig = "small";
  setup.cameras = {0, 1, 2};
  ScanAndReport(state, setup, 60);
  state.SetLabel(setup.scene);
}
BENCHMARK(WholeSessionAcceptance)->Arg(0)->Arg(1)->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
