// The BTF as the matrix A of a factor layout (core/btf.h), read from a
// FullBtfReader in bands, and the block products over it that the streamed
// passes of CompressBtf make. Internal to btf/: the SVD, the factorizations
// and RelativeRmsError share it.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <functional>
#include <vector>

#include "core/btf.h"

namespace mesocap::btf::compression {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// A block of the BTF matrix A of a layout, all three RGB channels, as
// BtfMatrix::Read gives it for rows [r0, r0 + rows) x columns [c0, c0 +
// columns): column-major, the RGB of A(r0 + i, c0 + j) at
// rgb[3 * (j * rows + i)]. Column j of A is a view image (paper) or one
// light's slice of one (per_texel); row p is the pixel index inside it
// (p = y * W + x), so a block of whole texture lines is a run of rows of
// each view image. The reader of a block knows its r0 and c0.
struct MatrixBlock {
  long long rows = 0, columns = 0;
  std::vector<float> rgb;

  // out = weights . A(r0 + i0 .. + count, the block's columns).
  void FillRows(long long i0, long long count, const Eigen::Vector3d& w, MatrixXd* out) const {
    out->resize(count, columns);
    for (long long j = 0; j < columns; ++j) {
      const float* base = rgb.data() + 3 * (j * rows + i0);
      for (long long i = 0; i < count; ++i) (*out)(i, j) = Weighted(w, base + 3 * i);
    }
  }
  // out = (weights . A(the block's rows, c0 + j0 .. + count))^T.
  void FillTransposedRows(long long j0, long long count, const Eigen::Vector3d& w, MatrixXd* out) const {
    out->resize(count, rows);
    for (long long j = 0; j < count; ++j) {
      const float* base = rgb.data() + 3 * (j0 + j) * rows;
      for (long long i = 0; i < rows; ++i) (*out)(j, i) = Weighted(w, base + 3 * i);
    }
  }
  static double Weighted(const Eigen::Vector3d& w, const float* rgb) {
    return w[0] * rgb[0] + w[1] * rgb[1] + w[2] * rgb[2];
  }
};

// The BTF as the matrix A of a layout, read from `btf` in blocks.
class BtfMatrix {
 public:
  BtfMatrix(core::FullBtfReader& btf, core::BtfFactorLayout layout) : btf_(btf), layout_(layout) {
    const long long texels = static_cast<long long>(btf.width()) * btf.height();
    rows_ = layout == core::BtfFactorLayout::kPaper ? texels * btf.light_count() : texels;
    columns_ = layout == core::BtfFactorLayout::kPaper ? btf.view_count()
                                                       : static_cast<long long>(btf.view_count()) * btf.light_count();
  }

  long long rows() const { return rows_; }
  long long columns() const { return columns_; }
  int width() const { return btf_.width(); }

  // Rows and columns as above; first_row and rows whole texture lines
  // (multiples of the width), which every band below is.
  MatrixBlock Read(long long first_row, long long rows, long long first_column, long long columns) const;

 private:
  core::FullBtfReader& btf_;
  core::BtfFactorLayout layout_;
  long long rows_ = 0;
  long long columns_ = 0;
};

// The matrix a pass streams: A, or A^T when A is wider than tall; its rows
// come in bands, each band one block of A read from the BTF.
class StreamedMatrix {
 public:
  StreamedMatrix(const BtfMatrix& a, bool transposed, long long band_bytes)
      : a_(a), transposed_(transposed), band_bytes_(band_bytes) {}

  long long rows() const { return transposed_ ? a_.columns() : a_.rows(); }
  long long columns() const { return transposed_ ? a_.rows() : a_.columns(); }

  // Calls body(band, first, count) for the bands of rows [first, first +
  // count) in order; one band in memory at a time.
  void ForEachBand(const std::function<void(const MatrixBlock&, long long, long long)>& body) const;
  // Rows [i0, i0 + count) of a band (relative to it), one channel.
  void Fill(const MatrixBlock& band, long long i0, long long count, const Eigen::Vector3d& w, MatrixXd* out) const {
    if (transposed_) {
      band.FillTransposedRows(i0, count, w, out);
    } else {
      band.FillRows(i0, count, w, out);
    }
  }

 private:
  const BtfMatrix& a_;
  bool transposed_;
  long long band_bytes_;
};

using ChannelWeights = std::array<Eigen::Vector3d, 3>;

// Row blocks of the passes that only multiply (no QR): about 2 MiB of
// doubles, and at least 256 rows, so that each block's product reuses the
// other factor (n x l, megabytes on a wide matrix) instead of streaming it
// from memory for a few rows.
inline long long ProductBlockRows(long long n) {
  return std::max<long long>(256, (1 << 18) / std::max<long long>(n, 1));
}

// One pass over the row blocks of the streamed matrix S, every channel:
// body(ch, first_row, block) runs in parallel, each call for its own rows.
void ForEachRowBlock(const StreamedMatrix& s, const ChannelWeights& weights,
                     const std::function<void(int, long long, const MatrixXd&)>& body);

// One pass computing S(rows, :) * right[ch] for every row block of the
// streamed matrix S and channel; sink(ch, first_row, product) runs in
// parallel, each call for its own rows.
void ForEachProduct(const StreamedMatrix& s, const ChannelWeights& weights, const std::array<MatrixXd, 3>& right,
                    const std::function<void(int, long long, const MatrixXd&)>& sink);

// S^T * left[ch] (left: S's rows x l) per channel in one pass. Each band's
// rows are split into a fixed number of chunks per channel, each chunk adding
// into its own partial sum across the bands; the partials are summed in
// chunk order at the end, so the result does not depend on the thread count.
std::array<MatrixXd, 3> TransposedProducts(const StreamedMatrix& s, const ChannelWeights& weights,
                                           const std::array<MatrixXd, 3>& left);

}  // namespace mesocap::btf::compression
