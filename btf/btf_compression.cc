#include "btf/btf_compression.h"

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "btf/btf_compression_report.h"
#include "btf/btf_factorization.h"
#include "btf/btf_representation_choice.h"

namespace mesocap::btf {
namespace {

// Up to this many bytes of float RGB a BTF is held in memory where it is
// read many times (a choice of representation, the clustered layout).
constexpr long long kMaxInMemoryBtfBytes = 2LL << 30;

// Bytes of the whole BTF in float RGB.
long long FullBtfBytes(const core::FullBtfReader& btf) {
  return static_cast<long long>(btf.width()) * btf.height() * btf.view_count() * btf.light_count() * 3 *
         static_cast<long long>(sizeof(float));
}

// The BTF of `btf` whole in memory, its views read in parallel.
core::FullBtf HoldInMemory(core::FullBtfReader& btf) {
  core::FullBtf whole = core::MakeFullBtf(btf.width(), btf.height(), btf.views(), btf.lights());
  tbb::parallel_for(0, btf.view_count(), [&](int v) {
    core::Image& image = whole.view_images[v];
    btf.ReadRows(v, 0, image.height(), image.data());
  });
  return whole;
}

}  // namespace

core::CheckResult BtfCompressionOptions::Check() const {
  if (rank < 0 || rank > core::kMaxBtfRank) {
    return "rank " + std::to_string(rank) + " is outside 0..100 (0 chooses the rank by the error budget)";
  }
  if (rank > 0 && (!layout || !color)) {
    return "rank " + std::to_string(rank) +
           " fixes the size of one representation: give its layout and colour "
           "too, or a budget (error or bytes) "
           "to choose among them";
  }
  if (max_bytes < 0) return "max_bytes " + std::to_string(max_bytes) + " must be positive (0: no byte budget)";
  if (max_bytes > 0 && rank > 0) return "give either a rank or max_bytes, not both";
  if (band_bytes < 1) return "band_bytes " + std::to_string(band_bytes) + " must be positive";
  if (power_iterations < 0 || power_iterations > 10) {
    return "power_iterations " + std::to_string(power_iterations) + " is outside 0..10";
  }
  if (clusters < 0 || clusters > core::kMaxBtfClusters) {
    return "clusters " + std::to_string(clusters) + " is outside 0.." + std::to_string(core::kMaxBtfClusters) +
           " (0 tries several)";
  }
  if (rank == 0 && max_bytes == 0 &&
      !(std::isfinite(max_relative_error) && max_relative_error > 0.0 && max_relative_error <= 1.0)) {
    return "max_relative_error " + std::to_string(max_relative_error) + " is outside (0, 1]";
  }
  return {};
}

namespace compression {
namespace {

// A choice among the representations the options allow, as the stages of
// Compress fill it in.
struct RepresentationChoice {
  RepresentationChoice(const core::FullBtfReader& btf, const BtfCompressionOptions& options)
      : options(options),
        candidates(AllowedRepresentations(options)),
        choosing(candidates.size() > 1),
        byte_budget(options.max_bytes > 0),
        texels(static_cast<long long>(btf.width()) * btf.height()),
        full_bytes(FullBtfBytes(btf)) {}

  const BtfCompressionOptions& options;
  std::vector<BtfRepresentationCandidate> candidates;
  const bool choosing;
  const bool byte_budget;
  const long long texels;
  const long long full_bytes;
  // The best so far: its factors when they were built to settle its error,
  // else its SVD, built once the choice is made.
  core::FactoredBtf best;
  BtfCompressionReport best_report;
  std::optional<Factorization> best_unbuilt;
  BtfCompressionOptions best_options;
  int best_index = -1;
};

// The options candidate c is factored with, a byte budget turned into its
// rank; none where it is not tried (its note says why), and an error where
// it is the only representation allowed.
std::optional<BtfCompressionOptions> OptionsFor(const core::FullBtfReader& btf, const core::FullBtf* whole,
                                                const RepresentationChoice& choice, BtfRepresentationCandidate& c) {
  const BtfCompressionOptions& options = choice.options;
  const std::string name = RepresentationName(c.layout, c.color, c.clusters);
  if (c.layout == core::BtfFactorLayout::kClustered && !whole) {
    c.note = "not tried: the clustered layout holds the whole BTF in memory, and this one is over " +
             Bytes(kMaxInMemoryBtfBytes);
    if (!choice.choosing) throw core::Error("compress: " + name + " " + c.note);
    return std::nullopt;
  }
  BtfCompressionOptions one = options;
  if (choice.byte_budget) {
    const long long ids = c.layout == core::BtfFactorLayout::kClustered ? choice.texels * 4 : 0;
    const long long per_rank =
        FactorBytes(c.layout, btf.width(), btf.height(), btf.view_count(), btf.light_count(), 1, c.clusters) - ids;
    one.rank = static_cast<int>(std::clamp<long long>((options.max_bytes - ids) / per_rank, 0, core::kMaxBtfRank));
    if (one.rank == 0) {
      c.factor_bytes = per_rank + ids;
      c.note = "not tried: rank 1 takes " + std::to_string(c.factor_bytes) + " bytes";
      if (!choice.choosing) {
        throw core::Error("compress: max_bytes " + std::to_string(options.max_bytes) + " is less than rank 1 of " +
                          name + " (" + std::to_string(c.factor_bytes) + " bytes)");
      }
      return std::nullopt;
    }
  }
  return one;
}

// Candidate i's SVD, and its factors too where the spectrum cannot settle
// its error; kept as the best if it beats the best so far.
void TryRepresentation(core::FullBtfReader& btf, const core::FullBtf* whole, std::size_t i,
                       RepresentationChoice& choice) {
  BtfRepresentationCandidate& c = choice.candidates[i];
  const std::string name = RepresentationName(c.layout, c.color, c.clusters);
  std::optional<BtfCompressionOptions> tried = OptionsFor(btf, whole, choice, c);
  if (!tried) return;
  BtfCompressionOptions& one = *tried;
  const auto factored_at = std::chrono::steady_clock::now();
  Factorization f = c.layout == core::BtfFactorLayout::kClustered ? FactorClustered(*whole, c.clusters, c.color)
                    : c.layout == core::BtfFactorLayout::kPerView
                        ? FactorPerView(btf, c.color)
                        : FactorOneRepresentation(btf, one, c.layout, c.color);
  c.clusters = f.shape.cluster_count;
  // A byte budget's rank, at most what this representation can hold (its
  // clusters' sizes, its rows of column factors).
  if (choice.byte_budget) one.rank = std::min(one.rank, f.report.max_rank);
  std::string reason;
  c.rank = ChooseRank(one, c.color, f.report, &reason);
  c.factor_bytes = f.Bytes(c.rank);
  c.relative_rms_error = f.report.relative_rms_error[c.rank - 1];
  core::FactoredBtf built;
  BtfCompressionReport built_report;
  if (c.color != core::BtfFactorColor::kRgb) {
    // Under an error budget the rank only grows from the spectrum's while
    // the measured RGB error is over the budget: at least these bytes.
    const BtfRepresentationCandidate* leader = choice.best_index >= 0 ? &choice.candidates[choice.best_index] : nullptr;
    if (choice.choosing && !choice.byte_budget && leader && leader->meets_budget &&
        c.factor_bytes >= leader->factor_bytes) {
      c.note = "not built: its spectrum's rank " + std::to_string(c.rank) + " (" + Percent(c.relative_rms_error) +
               " in Y, Cb, Cr) already takes " + Bytes(c.factor_bytes) + ", no less than " +
               RepresentationName(leader->layout, leader->color, leader->clusters);
      return;
    }
    built = BuildAtChosenRank(btf, one, f, built_report);
    c.rank = built_report.rank;
    c.factor_bytes = built_report.factor_bytes;
    c.relative_rms_error = built_report.measured_relative_rms_error;
    c.measured = true;
  }
  JudgeAgainstBudget(choice.options, choice.full_bytes, c);
  spdlog::info("compress: {}: rank {}, {}, {} {}({:.1f} s)", name, c.rank, Bytes(c.factor_bytes),
               Percent(c.relative_rms_error), c.measured ? "measured " : "from the spectrum ",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - factored_at).count());
  if (choice.best_index < 0 || Better(c, choice.candidates[choice.best_index], choice.byte_budget)) {
    choice.best_index = static_cast<int>(i);
    choice.best_options = one;
    if (c.measured) {
      choice.best = std::move(built);
      choice.best_report = std::move(built_report);
      choice.best_unbuilt.reset();
    } else {
      choice.best_unbuilt = std::move(f);
    }
  }
}

// The factors of the representation kept, where its spectrum settled its
// error and they are not built yet, measured against the BTF.
void BuildTheChosen(core::FullBtfReader& btf, RepresentationChoice& choice) {
  if (choice.best_index >= 0 && choice.best_unbuilt) {
    BtfRepresentationCandidate& c = choice.candidates[choice.best_index];
    choice.best = BuildAtChosenRank(btf, choice.best_options, *choice.best_unbuilt, choice.best_report);
    choice.best_unbuilt.reset();
    c.rank = choice.best_report.rank;
    c.factor_bytes = choice.best_report.factor_bytes;
    c.relative_rms_error = choice.best_report.measured_relative_rms_error;
    c.measured = true;
    JudgeAgainstBudget(choice.options, choice.full_bytes, c);
  }
}

// Every representation was left out (OptionsFor); the error names the byte
// budget, the usual cause.
void ThrowIfNoneWasTried(const RepresentationChoice& choice) {
  const std::vector<BtfRepresentationCandidate>& candidates = choice.candidates;
  if (choice.best_index < 0) {
    throw core::Error(
        "compress: max_bytes " + std::to_string(choice.options.max_bytes) +
        " is less than rank 1 of every representation (the smallest: " +
        std::to_string(std::min_element(candidates.begin(), candidates.end(),
                                        [](const auto& a, const auto& b) { return a.factor_bytes < b.factor_bytes; })
                           ->factor_bytes) +
        " bytes)");
  }
}

// The report of the representation kept, and with a choice, why it was kept
// and every candidate.
void ReportTheChoice(RepresentationChoice& choice, BtfCompressionReport& r) {
  const BtfCompressionOptions& options = choice.options;
  std::vector<BtfRepresentationCandidate>& candidates = choice.candidates;
  const int best_index = choice.best_index;
  if (!choice.byte_budget && options.rank == 0 && !candidates[best_index].meets_budget && !choice.choosing) {
    choice.best_report.reason += candidates[best_index].note.empty() ? "" : "; " + candidates[best_index].note;
  }
  r = std::move(choice.best_report);
  if (choice.choosing) {
    const BtfRepresentationCandidate& c = candidates[best_index];
    const std::string name = RepresentationName(c.layout, c.color, c.clusters);
    const std::string figures =
        "rank " + std::to_string(c.rank) + ", " + Bytes(c.factor_bytes) + ", " + Percent(c.relative_rms_error);
    if (choice.byte_budget) {
      r.representation_reason = name + ": the most accurate of " + std::to_string(candidates.size()) +
                                " representations within " + Bytes(options.max_bytes) + " (" + figures + ")";
    } else if (c.meets_budget) {
      r.representation_reason = name + ": the smallest of the representations that meet the budget " +
                                Percent(options.max_relative_error) + " (" + figures + ")";
    } else {
      r.representation_reason = name + ": no representation meets the budget " + Percent(options.max_relative_error) +
                                " in fewer bytes than the full BTF (" + Bytes(choice.full_bytes) + ") up to rank " +
                                std::to_string(core::kMaxBtfRank) + "; the most accurate (" + figures + ")";
    }
    r.candidates = std::move(candidates);
  }
}

// CompressBtf over `btf`; `whole` is the same BTF in memory, or null where it
// is not held (then the clustered layout is not tried).
core::FactoredBtf Compress(core::FullBtfReader& btf, const core::FullBtf* whole, const BtfCompressionOptions& options,
                           BtfCompressionReport* report) {
  const auto start = std::chrono::steady_clock::now();
  BtfCompressionReport local;
  BtfCompressionReport& r = report ? *report : local;
  RepresentationChoice choice(btf, options);
  for (std::size_t i = 0; i < choice.candidates.size(); ++i) TryRepresentation(btf, whole, i, choice);
  BuildTheChosen(btf, choice);
  ThrowIfNoneWasTried(choice);
  ReportTheChoice(choice, r);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return std::move(choice.best);
}

}  // namespace
}  // namespace compression

core::FactoredBtf CompressBtf(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                              BtfCompressionReport* report) {
  core::ThrowIfInvalid(options.Check(), "compress");
  // A choice or the clustered layout makes many passes over the BTF (an SVD
  // and its factors per representation): below kMaxInMemoryBtfBytes it is
  // read once and held, rather than decoded from its files on every pass.
  const long long bytes = FullBtfBytes(btf);
  const bool many_passes = !options.layout || !options.color || *options.layout == core::BtfFactorLayout::kClustered;
  if (!many_passes || bytes > kMaxInMemoryBtfBytes) return compression::Compress(btf, nullptr, options, report);
  core::CheckMemoryFor(bytes, "the " + std::to_string(btf.width()) + "x" + std::to_string(btf.height()) +
                                  " BTF held in memory while it is factored");
  const auto read_at = std::chrono::steady_clock::now();
  const core::FullBtf whole = HoldInMemory(btf);
  spdlog::info("compress: read the BTF into memory ({}) in {:.1f} s", compression::Bytes(bytes),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - read_at).count());
  core::InMemoryFullBtfReader reader(whole);
  return compression::Compress(reader, &whole, options, report);
}

core::FactoredBtf CompressBtf(const core::FullBtf& btf, const BtfCompressionOptions& options,
                              BtfCompressionReport* report) {
  core::ThrowIfInvalid(options.Check(), "compress");
  core::InMemoryFullBtfReader reader(btf);
  if (!options.layout || *options.layout == core::BtfFactorLayout::kClustered) {
    // The clustered layout reads `btf` in place, past the reader's check
    // for non-finite values: that check runs here, a view at a time.
    std::vector<float> view(static_cast<std::size_t>(3) * btf.width * btf.height * btf.light_count());
    for (int v = 0; v < btf.view_count(); ++v) reader.ReadRows(v, 0, btf.height * btf.light_count(), view.data());
  }
  return compression::Compress(reader, &btf, options, report);
}

}  // namespace mesocap::btf
