#include "btf/btf_representation_choice.h"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "btf/btf_compression_report.h"

namespace mesocap::btf {
namespace compression {

std::vector<BtfRepresentationCandidate> AllowedRepresentations(const BtfCompressionOptions& options) {
  std::vector<core::BtfFactorLayout> layouts{core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel,
                                             core::BtfFactorLayout::kClustered, core::BtfFactorLayout::kPerView};
  std::vector<core::BtfFactorColor> colors{core::BtfFactorColor::kRgb, core::BtfFactorColor::kYCbCr};
  if (options.layout) layouts = {*options.layout};
  if (options.color) colors = {*options.color};
  std::vector<BtfRepresentationCandidate> candidates;
  for (const core::BtfFactorColor color : colors) {
    for (const core::BtfFactorLayout layout : layouts) {
      std::vector<int> counts{1};
      if (layout == core::BtfFactorLayout::kClustered)
        counts = options.clusters > 0 ? std::vector<int>{options.clusters} : std::vector<int>{8, 32, 128};
      for (const int clusters : counts) {
        BtfRepresentationCandidate c;
        c.layout = layout;
        c.color = color;
        c.clusters = clusters;
        candidates.push_back(c);
      }
    }
  }
  return candidates;
}

void JudgeAgainstBudget(const BtfCompressionOptions& options, long long full_bytes, BtfRepresentationCandidate& c) {
  const bool byte_budget = options.max_bytes > 0;
  c.meets_budget = byte_budget ? c.factor_bytes <= options.max_bytes
                               : options.rank > 0 || (c.relative_rms_error <= options.max_relative_error &&
                                                      c.factor_bytes < full_bytes);
  if (!byte_budget && options.rank == 0 && c.relative_rms_error <= options.max_relative_error && !c.meets_budget) {
    c.note = "meets the error budget only in at least as many bytes as the full BTF (" + Bytes(full_bytes) + ")";
  }
}

int ChooseRank(const BtfCompressionOptions& options, core::BtfFactorColor color, const BtfCompressionReport& r,
               std::string* reason) {
  const std::string space = color == core::BtfFactorColor::kRgb ? "" : " (in Y, Cb, Cr)";
  int rank = 0;
  if (options.rank > 0) {
    rank = std::min(options.rank, r.max_rank);
    *reason = rank == options.rank
                  ? "rank " + std::to_string(rank) + " as requested"
                  : "rank " + std::to_string(options.rank) + " requested, but the " + std::to_string(r.matrix_rows) +
                        " x " + std::to_string(r.matrix_columns) + " matrix has at most rank " + std::to_string(rank);
  } else {
    rank = r.max_rank;
    for (int k = 1; k <= r.max_rank; ++k) {
      if (r.relative_rms_error[k - 1] <= options.max_relative_error) {
        rank = k;
        break;
      }
    }
    *reason = r.relative_rms_error[rank - 1] <= options.max_relative_error
                  ? "smallest rank with relative RMS error" + space + " " + Percent(r.relative_rms_error[rank - 1]) +
                        " <= budget " + Percent(options.max_relative_error) +
                        (rank > 1 ? " (rank " + std::to_string(rank - 1) + ": " +
                                        Percent(r.relative_rms_error[rank - 2]) + ")"
                                  : "")
                  : "budget " + Percent(options.max_relative_error) + " not reachable: the largest rank " +
                        std::to_string(rank) + " leaves " + Percent(r.relative_rms_error[rank - 1]);
  }
  return rank;
}

core::FactoredBtf BuildAtChosenRank(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                                    const Factorization& f, BtfCompressionReport& r) {
  r = f.report;
  int rank = ChooseRank(options, f.shape.color, r, &r.reason);
  core::FactoredBtf out = f.shape;
  f.build(rank, &out);
  r.measured_relative_rms_error = RelativeRmsError(btf, out, options.band_bytes);
  if (options.rank == 0 && options.max_bytes == 0) {
    while (r.measured_relative_rms_error > options.max_relative_error && rank < r.max_rank) {
      f.build(++rank, &out);
      r.measured_relative_rms_error = RelativeRmsError(btf, out, options.band_bytes);
      r.reason = "rank " + std::to_string(rank) + ": smallest rank whose measured RGB error " +
                 Percent(r.measured_relative_rms_error) + " meets the budget " + Percent(options.max_relative_error);
    }
  }
  r.rank = rank;
  r.factor_bytes = f.Bytes(rank);
  out.CheckShape();
  spdlog::debug("compress: {} {}, {} x {} matrix per channel, rank {} ({})", ToString(out.layout), ToString(out.color),
                r.matrix_rows, r.matrix_columns, rank, r.reason);
  return out;
}

bool Better(const BtfRepresentationCandidate& c, const BtfRepresentationCandidate& best, bool byte_budget) {
  if (byte_budget || (!c.meets_budget && !best.meets_budget)) {
    return c.relative_rms_error < best.relative_rms_error ||
           (c.relative_rms_error == best.relative_rms_error && c.factor_bytes < best.factor_bytes);
  }
  if (c.meets_budget != best.meets_budget) return c.meets_budget;
  return c.factor_bytes < best.factor_bytes ||
         (c.factor_bytes == best.factor_bytes && c.relative_rms_error < best.relative_rms_error);
}

}  // namespace compression

long long FactorBytes(core::BtfFactorLayout layout, int width, int height, int views, int lights, int rank,
                      int clusters) {
  const bool paper = layout == core::BtfFactorLayout::kPaper;
  const bool clustered = layout == core::BtfFactorLayout::kClustered;
  const bool per_view = layout == core::BtfFactorLayout::kPerView;
  const long long texels = static_cast<long long>(width) * height;
  const long long row_pixels = texels * (paper ? lights : per_view ? views : 1);
  const long long columns = (paper ? views : static_cast<long long>(views) * lights) * (clustered ? clusters : 1);
  const long long bytes = 3LL * static_cast<long long>(sizeof(float)) * rank * (row_pixels + columns);
  return clustered ? bytes + texels * static_cast<long long>(sizeof(float)) : bytes;  // + the cluster ids
}

}  // namespace mesocap::btf
