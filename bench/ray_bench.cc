// Primary rays per second through each built-in scene, single-threaded, at
// theta 0, 45 and 75 degrees: random origins on the reference plane over
// 4 x 4 tiles, random azimuths, rays along -omega as for the MDF.
// items_per_second is rays per second. Beside it: the fraction of rays that
// hit, the mean hit distance (a checksum of the work done) and the mean
// number of tile cells a ray crosses in the slab (the cost driver at
// oblique angles). The tracer's error is tested, not benchmarked: distances
// match analytic and brute-force truth to 1e-9 relative (tests/sim).
#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include "core/angles.h"
#include "sim/cell_walk.h"
#include "sim/mesostructure_scene.h"

namespace {

using mesocap::sim::MesostructureScene;

struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d dir;
};

std::vector<Ray> PrimaryRays(const mesocap::sim::MesostructureScene& scene, double theta_deg, int count) {
  std::mt19937_64 rng(42);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double theta = mesocap::core::RadiansFromDegrees(theta_deg);
  std::vector<Ray> rays;
  for (int k = 0; k < count; ++k) {
    const double phi = 2.0 * std::numbers::pi * unit(rng);
    const Eigen::Vector3d omega(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    const Eigen::Vector3d origin(4.0 * scene.tile_size_mm() * unit(rng), 4.0 * scene.tile_size_mm() * unit(rng), 0.0);
    rays.push_back({origin, -omega});
  }
  return rays;
}

double MeanCells(const mesocap::sim::MesostructureScene& scene, const std::vector<Ray>& rays) {
  long cells = 0;
  for (const Ray& ray : rays) {
    mesocap::sim::CellWalk walk(ray.origin, ray.dir, 0.0, std::numeric_limits<double>::infinity(), scene.tile_size_mm(),
                                scene.d_max_mm());
    mesocap::sim::CellSpan span;
    while (walk.Next(&span)) ++cells;
  }
  return static_cast<double>(cells) / rays.size();
}

void PrimaryRaysPerSecond(benchmark::State& state, std::shared_ptr<const mesocap::sim::MesostructureScene> scene,
                          double theta_deg) {
  const std::vector<Ray> rays = PrimaryRays(*scene, theta_deg, 4096);
  long hits = 0;
  double distance_sum = 0.0;
  for (auto _ : state) {
    hits = 0;
    distance_sum = 0.0;
    for (const Ray& ray : rays) {
      const auto hit = scene->Intersect(ray.origin, ray.dir, 0.0, std::numeric_limits<double>::infinity());
      if (hit) {
        ++hits;
        distance_sum += hit->distance;
      }
    }
    benchmark::DoNotOptimize(distance_sum);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(rays.size()));
  state.counters["hit_fraction"] = static_cast<double>(hits) / rays.size();
  state.counters["mean_distance_mm"] = hits > 0 ? distance_sum / hits : 0.0;
  state.counters["cells_per_ray"] = MeanCells(*scene, rays);
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  for (const std::string& name : mesocap::sim::BuiltinSceneNames()) {
    std::shared_ptr<const mesocap::sim::MesostructureScene> scene = mesocap::sim::MakeBuiltinScene(name);
    for (const double theta : {0.0, 45.0, 75.0}) {
      benchmark::RegisterBenchmark(
          ("primary_rays/" + name + "/theta:" + std::to_string(static_cast<int>(theta))).c_str(), PrimaryRaysPerSecond,
          scene, theta)
          ->Unit(benchmark::kMicrosecond);
    }
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
