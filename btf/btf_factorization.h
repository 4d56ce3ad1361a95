// The factorizations CompressBtf chooses among, each an SVD of the BTF in
// one representation (layouts in core/btf.h): the paper and per_texel
// layouts' one matrix, the clustered layout's one per k-means cluster, the
// per_view layout's one per view. Internal to btf/.
#pragma once

#include <functional>

#include "btf/btf_compression.h"
#include "core/btf.h"

namespace mesocap::btf::compression {

// One representation after its SVD, before its factors are built. The
// spectrum gives the error of every rank: for rgb the RGB error itself
// (Eckart-Young: exact for the exact SVD, an upper bound for the randomized
// one, whose factors capture at least the sketch's energy), for ycbcr the
// error in the factored space only. So a choice among representations
// builds and measures only those the spectrum cannot settle.
struct Factorization {
  core::FactoredBtf shape;  // the size and representation, no factors
  // The spectrum, its error per rank, max_rank, the matrix size, svd.
  BtfCompressionReport report;
  // The factors of rank k into a copy of `shape`; holds the SVD.
  std::function<void(int, core::FactoredBtf*)> build;

  long long Bytes(int rank) const {
    return FactorBytes(shape.layout, shape.width, shape.height, shape.view_count(), shape.light_count(), rank,
                       shape.cluster_count);
  }
};

// The SVD of one representation in the paper or per_texel layout, the rank
// as options.rank or left to options.max_relative_error (max_bytes is turned
// into a rank by the caller).
Factorization FactorOneRepresentation(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                                      core::BtfFactorLayout layout, core::BtfFactorColor color);

// The clustered layout's k-means and per-cluster SVDs at `clusters`
// clusters; each cluster's factors are kept up to the largest rank a budget
// may choose.
Factorization FactorClustered(const core::FullBtf& btf, int clusters, core::BtfFactorColor color);

// The per-view factorisation (Sattler et al. 2003): each view's texels x
// lights matrix A_v gets its own SVD, one rank for all views. A_v is tall
// (texels) and narrow (lights), so its SVD is taken directly (Eigen BDCSVD,
// accurate to rounding, not through A_v^T A_v). Only each view's right
// singular vectors (Nlight x K) are kept; the row factors A_v v_k are
// computed from the data when the factors are built, a second read of the
// views, so memory stays at one view per worker.
Factorization FactorPerView(core::FullBtfReader& btf, core::BtfFactorColor color);

}  // namespace mesocap::btf::compression
