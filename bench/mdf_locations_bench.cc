// MDF error against the number of laser locations (issue 4, 7a): the small
// rig, scene blocks, camera 1 (33.75 degrees), turntable angle 0, default
// sensor noise, 1 to all 8 locations (spread over sides and mounts in the
// order 0 4 7 2 5 1 6 3). Frames are rendered by the simulated rig and fed
// to the streaming code in memory; the reported time is the processing
// alone (line detection, space-time analysis, triangulation, resampling,
// merging), the rendering excluded. Errors in texel widths (0.3125 mm),
// coverage inside the sample pocket (processing/mdf_evaluation.h).
#include <benchmark/benchmark.h>

#include <vector>

#include "processing/mdf_evaluation.h"
#include "tests/processing/simulated_scan.h"

namespace {

void ErrorAgainstLocations(benchmark::State& state) {
  const std::vector<int> order = {0, 4, 7, 2, 5, 1, 6, 3};
  mesocap::test::ScanSetup setup;
  setup.scene = "blocks";
  setup.rig = "small";
  setup.turntable_indices = {0};
  setup.cameras = {1};
  setup.locations.assign(order.begin(), order.begin() + state.range(0));
  mesocap::test::ScanResult r;
  for (auto _ : state) {
    r = mesocap::test::RunSimulatedScan(setup);
    state.SetIterationTime(r.processing_seconds);
  }
  const auto row = mesocap::EvaluateMdfViews(r.truth, r.estimate, r.texel_mm, {0, 90, true});
  state.counters["locations"] = static_cast<double>(state.range(0));
  state.counters["median_texels"] = row.median_texels;
  state.counters["p95_texels"] = row.p95_texels;
  state.counters["coverage"] = row.coverage;
  state.counters["processing_s"] = r.processing_seconds;
}
BENCHMARK(ErrorAgainstLocations)->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Iterations(1)->UseManualTime()->Unit(
    benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
