// The SVD numerics of CompressBtf (btf/btf_compression.h's opening comment
// says why each is used): the exact SVD of a streamed matrix (TSQR, then the
// SVD of R), the randomized one (Halko et al. 2011), the errors per rank a
// spectrum gives, and the SVD of a matrix in memory through a QR of its long
// side. Internal to btf/.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "btf/streamed_btf_matrix.h"

namespace mesocap::btf::compression {

// The exact SVD (TSQR, O(m n^2) and n^2 doubles per channel) up to this many
// columns of the streamed matrix; the randomized one beyond (auto).
constexpr long long kMaxExactSvdColumns = 2048;
// Sketch columns beyond the largest rank kept (Halko et al. 2011 Sec. 4.2).
constexpr long long kRandomizedOversampling = 10;

struct ChannelSvd {
  VectorXd sigma;  // min(rows, n), descending
  MatrixXd right;  // n x min(rows, n): right singular vectors of the streamed matrix
};

// Singular values and right singular vectors of the three channels'
// streamed matrices: one pass over the BTF, then the SVD of each small R.
std::array<ChannelSvd, 3> TallSkinnySvd(const StreamedMatrix& s, const ChannelWeights& weights);

// Randomized SVD (Halko, Martinsson & Tropp 2011, Algs. 4.4 and 5.1): a
// Gaussian sketch Y = S Omega of `components` columns (fixed seed), refined
// by `power_iterations` rounds of Y = S (S^T Q), each re-orthonormalized
// (Householder QR of the in-memory m x l sketch), then B^T = S^T Q and the
// exact SVD of that n x l matrix. 2 + 2 q passes over the BTF, O(m n l)
// work and O((m + n) l) memory, against TSQR's O(m n^2) and n^2.
// Conditioning: the leading singular values are underestimates whose error
// shrinks like (sigma_{l+1} / sigma_k)^(2q+1); a flat spectrum (noise) gains
// little from q. The factors built from it are measured against the data
// afterwards, so the error reported is exact whatever the sketch missed.
// energy[ch] = ||S_ch||_F^2, summed in the sketch pass for the error per rank.
std::array<ChannelSvd, 3> RandomizedSvd(const StreamedMatrix& s, const ChannelWeights& weights, long long components,
                                        int power_iterations, std::array<double, 3>* energy);

// Relative error at every rank from a truncated spectrum (randomized SVD):
// the tail is the channels' energy ||S||_F^2 minus the leading sigma^2,
// exact up to cancellation, so errors below ~1e-8 read as 0 here.
std::vector<double> TruncatedSpectrumErrors(const std::array<VectorXd, 3>& sigma, const std::array<double, 3>& energy,
                                            int max_rank);

// Relative error at every rank 1..max_rank from the spectra: the tail sums of
// sigma^2 are summed from the small end, so tiny errors are not lost to
// cancellation against ||A||^2.
template <typename Spectra>
std::vector<double> SpectrumErrors(const Spectra& sigma, int max_rank) {
  double total = 0.0;
  for (const VectorXd& s : sigma) total += s.squaredNorm();
  std::vector<double> errors(max_rank, 0.0);
  if (!(total > 0.0)) return errors;
  for (int k = 1; k <= max_rank; ++k) {
    double tail = 0.0;
    for (const VectorXd& s : sigma) {
      for (long long i = s.size() - 1; i >= k; --i) tail += s[i] * s[i];
    }
    errors[k - 1] = std::sqrt(tail / total);
  }
  return errors;
}

// The SVD of a (m x n): all min(m, n) singular values, and the leading
// `keep` left singular vectors times sigma (m x keep) and right singular
// vectors (n x keep). The longer side is reduced first by a Householder QR
// of the tall orientation, t = Q R, and the SVD taken of the small square R
// (Eigen BDCSVD). Both steps are backward stable, as a's own
// bidiagonalization is, at a third of its cost where one side is several
// times the other (a cluster of 2000 texels by 9216 directions).
struct TruncatedSvd {
  VectorXd sigma;
  MatrixXd left_scaled;
  MatrixXd right;
};

TruncatedSvd QrSvd(const MatrixXd& a, long long keep);

}  // namespace mesocap::btf::compression
