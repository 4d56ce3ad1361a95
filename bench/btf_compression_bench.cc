// SVD compression of BTFs (Wang et al. 2005 Sec. 5), speed against error:
//  - Material/<scene>/<rank>: the exact BTF of weave, blocks and grass
//    (sim ground truth, 32 x 32 texels, paper12x8 views and lights) factored
//    at rank K in the paper layout; counters: the measured relative RMS error
//    of the factors and sigma_K / sigma_1 of the luminance-like first
//    channel. The full spectrum and error per rank are printed as a table.
//  - PaperSize: a paper-rig-sized BTF (128 x 128 texels, 96 x 96 directions,
//    RGB floats: its size is in docs/FORMATS.md; synthetic smooth data plus
//    noise, since a ground truth of that size takes minutes to render)
//    factored at rank 4;
//    counters: achieved GFLOP/s of the streamed QR + factor products
//    (2 m n^2 + 2 m n K per channel) and its ratio to a double-precision
//    matrix multiply (Eigen GEMM, 1024^2) measured in the same run, and the
//    peak resident memory during the compression (peak_mib).
//  - PaperSizePerTexel: the same BTF in the per_texel layout (16384 x 9216
//    per channel), which the randomized SVD factors; wall time, peak memory,
//    measured error against the spectrum's.
//  - PaperSizeFromPackage: the same BTF written to a material package and
//    compressed from its view files in bands (the out-of-core path of
//    `mesocap compress`); the same counters.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <Eigen/Core>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <random>

#include "btf/btf_compression.h"
#include "formats/material_manifest.h"
#include "formats/material_package_writer.h"
#include "formats/package_full_btf_reader.h"
#include "sim/ground_truth.h"
#include "sim/mesostructure_scene.h"

namespace mesocap {
namespace {

core::FullBtf SceneBtf(const std::string& name) {
  const auto scene = sim::MakeBuiltinScene(name);
  sim::GroundTruthOptions gt;
  gt.texels.width = gt.texels.height = 32;
  gt.texels.sample_size_mm = 12.0;
  gt.views = core::SamplingSet::Named("paper12x8");
  gt.lights = core::SamplingSet::Named("paper12x8");
  return sim::RenderTrueBtf(*scene, gt);
}

const core::FullBtf& CachedSceneBtf(const std::string& name) {
  static std::map<std::string, core::FullBtf> cache;
  auto it = cache.find(name);
  if (it == cache.end()) {
    it = cache.emplace(name, SceneBtf(name)).first;
    // The spectrum and the error per rank, once per scene.
    btf::BtfCompressionOptions o;
    o.rank = 1;
    btf::BtfCompressionReport r;
    btf::CompressBtf(it->second, o, &r);
    std::printf("# %s: %lld x %lld per channel; rank: sigma_k/sigma_1 (R), relative RMS error\n", name.c_str(),
                r.matrix_rows, r.matrix_columns);
    for (int k = 1; k <= r.max_rank; k *= 2) {
      std::printf("#   %2d: %.3e  %.4f\n", k, r.singular_values[0][k - 1] / r.singular_values[0][0],
                  r.relative_rms_error[k - 1]);
    }
  }
  return it->second;
}

void Material(benchmark::State& state, const std::string& name) {
  const core::FullBtf& btf = CachedSceneBtf(name);
  btf::BtfCompressionOptions o;
  o.rank = static_cast<int>(state.range(0));
  btf::BtfCompressionReport r;
  for (auto _ : state) benchmark::DoNotOptimize(btf::CompressBtf(btf, o, &r));
  state.counters["relative_rms"] = r.measured_relative_rms_error;
  state.counters["sigma_ratio"] = r.singular_values[0][o.rank - 1] / r.singular_values[0][0];
}

double GemmGflops() {
  const int n = 1024;
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(n, n), b = Eigen::MatrixXd::Random(n, n);
  Eigen::MatrixXd c(n, n);
  double best = 1e30;
  for (int rep = 0; rep < 3; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    c.noalias() = a * b;
    best = std::min(best, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    benchmark::DoNotOptimize(c.data());
  }
  return 2.0 * n * n * n / best * 1e-9;
}

// View v of the synthetic paper-size BTF (128 x 128 texels, paper12x8
// lights): smooth shading and texture plus noise drawn from `rng` in order.
core::Image PaperSizeView(const core::SamplingSet& set, int v, std::mt19937& rng) {
  std::normal_distribution<float> noise(0.0f, 0.002f);
  core::Image image(128, 128 * set.size(), 3);
  const Eigen::Vector3d vd = set.direction(v);
  for (int row = 0; row < image.height(); ++row) {
    const Eigen::Vector3d ld = set.direction(row / 128);
    const float shade = static_cast<float>(0.2 + 0.1 * vd.dot(ld) + 0.05 * ld.z());
    for (int x = 0; x < image.width(); ++x) {
      const float texture = 0.5f + 0.3f * std::sin(0.2f * x + 0.1f * (row % 128) + static_cast<float>(vd.x()));
      float* p = image.pixel(x, row);
      for (int c = 0; c < 3; ++c) p[c] = shade * texture * (1.0f - 0.2f * c) + noise(rng);
    }
  }
  return image;
}

// The process's peak resident memory since the last ResetPeakMemory, in
// MiB (Linux: VmHWM, reset through /proc/self/clear_refs); -1 if unknown.
void ResetPeakMemory() { std::ofstream("/proc/self/clear_refs") << "5"; }
double PeakMemoryMiB() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return -1.0;
}

void ReportPaperSize(benchmark::State& state, const btf::BtfCompressionReport& r, int rank) {
  const double m = static_cast<double>(r.matrix_rows), n = static_cast<double>(r.matrix_columns);
  const double flops = 3.0 * (2.0 * m * n * n + 2.0 * m * n * rank);
  const double gflops = flops / r.seconds * 1e-9;
  const double gemm = GemmGflops();
  state.counters["gflops"] = gflops;
  state.counters["gemm_gflops_1thread"] = gemm;
  state.counters["threads"] = static_cast<double>(std::thread::hardware_concurrency());
  state.counters["ratio_to_gemm_all_threads"] =
      gflops / (gemm * static_cast<double>(std::thread::hardware_concurrency()));
  state.counters["relative_rms"] = r.measured_relative_rms_error;
}

// The whole synthetic paper-size BTF in memory.
core::FullBtf PaperSizeBtf() {
  const core::SamplingSet set = core::SamplingSet::Named("paper12x8");
  core::FullBtf btf = core::MakeFullBtf(128, 128, set, set);
  std::mt19937 rng(1);
  for (int v = 0; v < btf.view_count(); ++v) btf.view_images[v] = PaperSizeView(set, v, rng);
  return btf;
}

void PaperSize(benchmark::State& state) {
  const core::FullBtf btf = PaperSizeBtf();
  btf::BtfCompressionOptions o;
  o.rank = 4;
  btf::BtfCompressionReport r;
  ResetPeakMemory();
  for (auto _ : state) benchmark::DoNotOptimize(btf::CompressBtf(btf, o, &r));
  state.counters["peak_mib"] = PeakMemoryMiB();
  ReportPaperSize(state, r, o.rank);
}

// The same BTF in the per_texel layout: a 16384 x 9216 matrix per channel,
// past the exact SVD's 2048 columns, so the randomized SVD factors it.
// Counters: wall seconds, peak memory, the measured error and the error the
// truncated spectrum predicts at that rank.
void PaperSizePerTexel(benchmark::State& state) {
  const core::FullBtf btf = PaperSizeBtf();
  btf::BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.rank = static_cast<int>(state.range(0));
  btf::BtfCompressionReport r;
  ResetPeakMemory();
  for (auto _ : state) benchmark::DoNotOptimize(btf::CompressBtf(btf, o, &r));
  state.counters["peak_mib"] = PeakMemoryMiB();
  state.counters["seconds"] = r.seconds;
  state.counters["relative_rms"] = r.measured_relative_rms_error;
  state.counters["spectrum_relative_rms"] = r.relative_rms_error[o.rank - 1];
  std::printf("# PaperSizePerTexel rank %d: %s\n", o.rank, r.svd.c_str());
}

// The same BTF written to a material package view by view (never whole in
// memory) and compressed from its files, as `mesocap compress` does: the
// peak memory of the compression is the band, the factors and the workers'
// blocks, not the whole BTF.
void PaperSizeFromPackage(benchmark::State& state) {
  const core::SamplingSet set = core::SamplingSet::Named("paper12x8");
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("mesocap-bench-paper-" + std::to_string(::getpid()));
  formats::MaterialDescription d;
  d.name = "paper-size synthetic";
  d.width = d.height = 128;
  d.physical_size_mm = {12.0, 12.0};
  d.d_max_mm = 1.0;
  d.view_directions = set;
  d.light_directions = set;
  {
    formats::MaterialPackageWriter writer(dir, d, true);
    std::mt19937 rng(1);
    for (int v = 0; v < set.size(); ++v) writer.WriteFullBtfView(v, PaperSizeView(set, v, rng));
    writer.Commit();
  }
  btf::BtfCompressionOptions o;
  o.rank = 4;
  btf::BtfCompressionReport r;
  ResetPeakMemory();
  for (auto _ : state) {
    formats::PackageFullBtfReader reader(dir, formats::ReadMaterialManifest(dir));
    benchmark::DoNotOptimize(btf::CompressBtf(reader, o, &r));
  }
  state.counters["peak_mib"] = PeakMemoryMiB();
  std::filesystem::remove_all(dir);
  ReportPaperSize(state, r, o.rank);
}

}  // namespace
}  // namespace mesocap

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  for (const char* scene : {"weave", "blocks", "grass"}) {
    benchmark::RegisterBenchmark((std::string("Material/") + scene).c_str(), mesocap::Material, std::string(scene))
        ->Arg(1)
        ->Arg(2)
        ->Arg(4)
        ->Arg(8)
        ->Arg(16)
        ->Arg(32)
        ->Unit(benchmark::kMillisecond);
  }
  benchmark::RegisterBenchmark("PaperSize", mesocap::PaperSize)->Unit(benchmark::kSecond)->Iterations(1);
  benchmark::RegisterBenchmark("PaperSizePerTexel", mesocap::PaperSizePerTexel)
      ->Arg(8)
      ->Unit(benchmark::kSecond)
      ->Iterations(1);
  benchmark::RegisterBenchmark("PaperSizeFromPackage", mesocap::PaperSizeFromPackage)
      ->Unit(benchmark::kSecond)
      ->Iterations(1);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
