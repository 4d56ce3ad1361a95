// SVD compression of a full BTF into eigenmaps and weight maps (Wang et al.
// 2005 Sec. 5): each colour channel's BTF matrix A (layouts in core/btf.h) is
// factored and truncated to rank K, A ~= sum_k r_k c_k^T, with the rank given
// or chosen as the smallest that meets a relative error budget (or the
// largest that fits a byte budget). The clustered layout (local PCA, Mueller
// et al. 2003) splits the texels by k-means and factors each cluster's A on
// its own; a cluster of one texel is exact at rank 1, and one of identical
// texels at rank 1 as well. The per_view layout (Sattler et al. 2003) gives
// each view's texels x lights matrix its own SVD, one rank for all views.
// With the layout or colour left open, every representation allowed is
// factored and the budget picks one; the spectra settle the choice where
// they can, so mostly only the one kept has its factors built and measured.
//
// Algorithm and conditioning: A is tall and skinny in the paper layout
// (W*H*Nlight rows, Nview columns). Its SVD is taken as a Householder QR of A,
// streamed over row blocks (TSQR: the R of each block stacked on the running
// R and re-factored), followed by the SVD of the small n x n factor R
// (Eigen BDCSVD). Both steps are backward stable, so singular values are
// accurate to ~eps * sigma_max -- unlike an eigen-decomposition of A^T A,
// which squares the condition number and loses every singular value below
// ~sqrt(eps) * sigma_max. Row factors are then r_k = A v_k (= sigma_k u_k),
// computed from the data, so the reconstruction sum_k r_k v_k^T is the
// orthogonal projection of A onto the leading right singular subspace and
// its error is ||A - A_K||_F up to rounding, however small sigma_k is.
// A matrix wider than tall (per_texel on a small texture) is factored through
// A^T, with c_k = A^T u_k / sigma_k; components with sigma_k below
// n * eps * sigma_max (numerically zero: exactly rank-deficient data, a
// constant-zero channel) get zero factors instead of a division by ~0.
//
// Where the streamed matrix is wide (over 2048 columns: per_texel on the
// paper rig's 96 x 96 directions), a randomized SVD replaces the exact one
// (BtfSvdMethod; Halko et al. 2011): a Gaussian sketch of rank + 10 columns
// refined by power iterations, 2 + 2q passes, O(m n (K + 10)) work.
//
// Memory: one fixed representation other than clustered reads the BTF
// through a FullBtfReader (core/btf.h) in bands of about band_bytes (64 MiB;
// whole texture lines x all columns, or whole columns when A is wide), one
// band at a time, so a BTF on disk (a material package) is never whole in
// memory: besides the band, one row block (~thousands of rows x n doubles)
// per worker, the n x n factors and the output factors (K images). Passes
// over the BTF: one for R, one for the remaining factor, one for the measured
// error (and two more per rank the ycbcr budget search adds). A choice of
// representation, or the clustered layout, reads the BTF once and holds it
// in memory (float) up to kMaxInMemoryBtfBytes (btf_compression.cc), under
// which a paper rig's BTF (docs/FORMATS.md) fits; beyond, the choice streams
// and leaves the clustered layout out.
#pragma once

#include <Eigen/Core>
#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/btf.h"
#include "core/enum_text.h"
#include "core/error.h"

namespace mesocap::btf {

// How each channel's matrix is factored: exactly (TSQR + SVD of R, see
// above), by a randomized SVD (sketch, power iterations, SVD of the small
// projection), or exactly up to 2048 columns of the streamed matrix and
// randomized beyond (auto), where the exact one's n x n factors take
// gigabytes and O(m n^2) time.
enum class BtfSvdMethod { kAuto, kExact, kRandomized };
constexpr auto EnumNamesOf(BtfSvdMethod) { return std::to_array({"auto", "exact", "randomized"}); }
using core::ToString;

struct BtfCompressionOptions {
  // The representation: a matrix layout and the channels factored. Either
  // left empty (std::nullopt) chooses it: every representation it allows is
  // factored, and the one that meets the budget in the fewest bytes (with
  // max_bytes: the most accurate within them) is kept.
  std::optional<core::BtfFactorLayout> layout = core::BtfFactorLayout::kPaper;
  std::optional<core::BtfFactorColor> color = core::BtfFactorColor::kRgb;
  // A fixed rank 1..kMaxBtfRank, or 0 to choose the smallest rank whose
  // relative RMS error (over all RGB values) is at most max_relative_error.
  // A fixed rank needs a fixed representation.
  int rank = 0;
  double max_relative_error = 0.01;
  // > 0: a budget in bytes instead of an error: the largest rank whose
  // factors (float32, as a material package stores them) fit.
  long long max_bytes = 0;
  // clustered: the number of clusters (1..kMaxBtfClusters); 0 tries 8, 32
  // and 128 as separate representations.
  int clusters = 0;
  // How much of the BTF a pass holds at a time: bands of about this many
  // bytes of float RGB (at least one texture line x all columns, or one
  // column). The result does not depend on it beyond rounding.
  long long band_bytes = 64LL << 20;
  BtfSvdMethod svd = BtfSvdMethod::kAuto;
  // Randomized SVD: power iterations (0..10), two passes over the BTF each.
  int power_iterations = 2;

  core::CheckResult Check() const;
};

// Bytes of the factors of rank `rank` (float32, 3 channels): the row factor
// images and the column factors (FactoredBtf).
// clustered: plus one float32 cluster id per texel, `clusters` times the
// column factors.
long long FactorBytes(core::BtfFactorLayout layout, int width, int height, int views, int lights, int rank,
                      int clusters = 1);

// One representation considered while choosing (BtfCompressionOptions with
// the layout or colour left empty). Each is factored (its SVD); its factors
// are built and measured only where the spectrum cannot settle the choice:
// an rgb representation's RGB error is its spectrum's (exact SVD; an upper
// bound for the randomized one), a ycbcr one's spectrum measures the error
// in Y, Cb, Cr.
struct BtfRepresentationCandidate {
  core::BtfFactorLayout layout = core::BtfFactorLayout::kPaper;
  core::BtfFactorColor color = core::BtfFactorColor::kRgb;
  int clusters = 1;  // clustered: the number of clusters
  int rank = 0;      // 0: not factored (see note)
  long long factor_bytes = 0;
  // RGB relative RMS error at `rank`: measured on built factors, or (not
  // measured) the spectrum's.
  double relative_rms_error = 0.0;
  bool measured = false;
  bool meets_budget = false;
  // Why it was not factored or not built, or why it does not meet the budget.
  std::string note;
};

struct BtfCompressionReport {
  // Per factored channel (R, G, B or Y, Cb, Cr), all min(rows, columns)
  // singular values, descending (the randomized SVD: its leading ones).
  std::array<Eigen::VectorXd, 3> singular_values;
  // relative_rms_error[K - 1]: ||A - A_K||_F / ||A||_F over the three
  // factored channels at rank K, from the spectrum (Eckart-Young), for
  // K = 1..max_rank. For rgb this is the RGB error; for ycbcr it is the
  // error in the factored (Y, Cb, Cr) space.
  std::vector<double> relative_rms_error;
  // Largest rank considered: min(kMaxBtfRank, rows, columns); with the
  // randomized SVD at a fixed rank, that rank.
  int max_rank = 0;
  int rank = 0;  // the chosen rank
  std::string reason;
  // Of the factors as returned (float), reconstructed and compared with the
  // input in RGB: ||T - T_K||_F / ||T||_F (0 when the BTF is all zero).
  double measured_relative_rms_error = 0.0;
  long long factor_bytes = 0;  // of the factors returned (FactorBytes)
  // When the representation was chosen: every one considered, in the order
  // tried, and why the one returned was kept.
  std::vector<BtfRepresentationCandidate> candidates;
  std::string representation_reason;
  long long matrix_rows = 0;
  long long matrix_columns = 0;
  // "exact", or "randomized (L components, Q power iterations)"; with the
  // randomized SVD singular_values holds the L leading ones only.
  std::string svd;
  double seconds = 0.0;  // wall time of CompressBtf
};

// Factors `btf`, choosing the representation when the options leave it open
// (an SVD per representation; factors built for the one kept and for the
// ycbcr ones that could beat it). Throws Error on invalid
// options, an empty or inconsistent BTF, a non-finite value (naming the
// view, texel and light), or a max_bytes below rank 1 of every
// representation allowed.
core::FactoredBtf CompressBtf(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                              BtfCompressionReport* report = nullptr);
core::FactoredBtf CompressBtf(const core::FullBtf& btf, const BtfCompressionOptions& options,
                              BtfCompressionReport* report = nullptr);

// The report as JSON (error_report.json's "btf_compression" member):
// layout, color, rank, reason, measured_relative_rms, factor_bytes,
// representation_reason and candidates (when chosen), relative_rms_by_rank
// (index K-1), singular_values per factored channel, matrix size, seconds.
nlohmann::json ToJson(const BtfCompressionReport& report, const core::FactoredBtf& factored);

// View `view` of the factored BTF as a full-BTF view image (3 channels,
// W x H * Nlight, linear RGB): sum_k r_k c_k per factored channel, then back
// to RGB. What an evaluation or a renderer's reference path reads.
core::Image ReconstructBtfView(const core::FactoredBtf& factored, int view);

// ||T - F||_F / ||T||_F over all texels, directions and RGB channels (0 when
// both are zero). Sizes must agree (throws Error otherwise).
// Streamed in bands of about band_bytes.
double RelativeRmsError(core::FullBtfReader& truth, const core::FactoredBtf& factored, long long band_bytes);
double RelativeRmsError(const core::FullBtf& truth, const core::FactoredBtf& factored);

}  // namespace mesocap::btf
