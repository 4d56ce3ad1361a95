// Rate against distortion of every BTF representation `compress` chooses
// from: for each ground-truth package given, each layout (paper, per_texel,
// clustered at 8, 32 and 128 clusters, per_view) and colour (rgb, ycbcr) is factored
// once at its largest rank, and its leading K components (the rank-K
// factors: truncating an SVD, or each cluster's or view's, gives the rank-K one) are
// measured against the exact BTF at a ladder of ranks, up to the size of the
// BTF itself (float32; beyond it a representation saves nothing). Prints CSV:
//   scene,representation,rank,bytes,bytes_per_texel,relative_rms,snr_db
// with snr_db = -20 log10(relative RMS), i.e. PSNR with the BTF's RMS as the
// peak. bench/rate_distortion_plot.sh turns it into PNG plots.
// Usage: mesocap_btf_rate_distortion_bench GROUND_TRUTH_PACKAGE...
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "btf/btf_compression.h"
#include "core/btf.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"

namespace mesocap {
namespace {

// The rank-K factors inside rank-R ones (K <= R): the first K row images and,
// per cluster, the first K rows of its column factors.
core::FactoredBtf LeadingComponents(const core::FactoredBtf& f, int rank) {
  core::FactoredBtf t = f;
  t.rows.assign(f.rows.begin(), f.rows.begin() + rank);
  t.columns = core::Image(f.columns.width(), rank * f.column_sets(), 3);
  for (int c = 0; c < f.column_sets(); ++c)
    for (int k = 0; k < rank; ++k)
      for (int x = 0; x < f.columns.width(); ++x)
        for (int ch = 0; ch < 3; ++ch) t.columns.at(x, c * rank + k, ch) = f.columns.at(x, c * f.rank() + k, ch);
  return t;
}

struct Representation {
  core::BtfFactorLayout layout;
  int clusters;
  core::BtfFactorColor color;
};

std::string Name(const Representation& r) {
  std::string name = core::ToString(r.layout);
  if (r.layout == core::BtfFactorLayout::kClustered) name += "(" + std::to_string(r.clusters) + ")";
  return name + "/" + core::ToString(r.color);
}

void Measure(const std::filesystem::path& package) {
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(package);
  const core::FullBtf truth = formats::ReadFullBtf(package, manifest);
  const int w = truth.width, h = truth.height, nv = truth.views.size(), nl = truth.lights.size();
  const std::string scene = package.filename().string();
  const long long btf_bytes = 12LL * w * h * nv * nl;
  std::vector<Representation> representations;
  for (const core::BtfFactorColor color : {core::BtfFactorColor::kRgb, core::BtfFactorColor::kYCbCr}) {
    representations.push_back({core::BtfFactorLayout::kPaper, 1, color});
    representations.push_back({core::BtfFactorLayout::kPerTexel, 1, color});
    for (const int clusters : {8, 32, 128})
      representations.push_back({core::BtfFactorLayout::kClustered, clusters, color});
    representations.push_back({core::BtfFactorLayout::kPerView, 1, color});
  }
  for (const Representation& r : representations) {
    const long long rows = r.layout == core::BtfFactorLayout::kPaper ? 1LL * w * h * nl : 1LL * w * h;
    const long long columns = r.layout == core::BtfFactorLayout::kPaper     ? nv
                              : r.layout == core::BtfFactorLayout::kPerView ? std::min(nl, core::kMaxBtfColumnRows / nv)
                                                                            : 1LL * nv * nl;
    btf::BtfCompressionOptions o;
    o.layout = r.layout;
    o.color = r.color;
    o.clusters = r.layout == core::BtfFactorLayout::kClustered ? r.clusters : 0;
    o.rank = static_cast<int>(std::min<long long>({core::kMaxBtfRank, rows, columns}));
    const core::FactoredBtf full = btf::CompressBtf(truth, o);
    for (const int rank : {1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 100}) {
      const long long bytes = btf::FactorBytes(r.layout, w, h, nv, nl, rank, full.cluster_count);
      if (rank > full.rank() || bytes >= btf_bytes) break;
      const double error = btf::RelativeRmsError(truth, LeadingComponents(full, rank));
      std::printf("%s,%s,%d,%lld,%.1f,%.6g,%.3f\n", scene.c_str(), Name(r).c_str(), rank, bytes,
                  static_cast<double>(bytes) / (1.0 * w * h), error, -20.0 * std::log10(std::max(error, 1e-300)));
      std::fflush(stdout);
    }
  }
}

}  // namespace
}  // namespace mesocap

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s GROUND_TRUTH_PACKAGE...\n", argv[0]);
    return 2;
  }
  std::printf("scene,representation,rank,bytes,bytes_per_texel,relative_rms,snr_db\n");
  try {
    for (int i = 1; i < argc; ++i) mesocap::Measure(argv[i]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
