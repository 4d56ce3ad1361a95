#include "btf/streamed_btf_matrix.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>

namespace mesocap::btf::compression {
namespace {

// Row bands of A: whole texture lines, all columns, about `bytes` of floats.
long long RowBandRows(const BtfMatrix& a, long long bytes) {
  const long long line = static_cast<long long>(a.width()) * a.columns() * 3 * sizeof(float);
  return a.width() * std::max<long long>(1, bytes / line);
}

// Column bands of A: whole columns, all rows.
long long ColumnBandColumns(const BtfMatrix& a, long long bytes) {
  return std::max<long long>(1, bytes / (a.rows() * 3 * static_cast<long long>(sizeof(float))));
}

}  // namespace

MatrixBlock BtfMatrix::Read(long long first_row, long long rows, long long first_column, long long columns) const {
  const int w = btf_.width();
  MatrixBlock block{rows, columns, {}};
  block.rgb.resize(static_cast<std::size_t>(3 * rows * columns));
  // The views in parallel (decoding a view file is the slow part), each
  // view's columns in order.
  const long long per_view = layout_ == core::BtfFactorLayout::kPaper ? 1 : btf_.light_count();
  const int first_view = static_cast<int>(first_column / per_view);
  const int last_view = static_cast<int>((first_column + columns - 1) / per_view);
  tbb::parallel_for(first_view, last_view + 1, [&](int view) {
    const long long begin = std::max(first_column, view * per_view);
    const long long end = std::min(first_column + columns, (view + 1) * per_view);
    for (long long c = begin; c < end; ++c) {
      const long long first_line = layout_ == core::BtfFactorLayout::kPaper ? 0 : (c % per_view) * btf_.height();
      btf_.ReadRows(view, static_cast<int>(first_line + first_row / w), static_cast<int>(rows / w),
                    block.rgb.data() + 3 * (c - first_column) * rows);
    }
  });
  return block;
}

void StreamedMatrix::ForEachBand(const std::function<void(const MatrixBlock&, long long, long long)>& body) const {
  const long long band = transposed_ ? ColumnBandColumns(a_, band_bytes_) : RowBandRows(a_, band_bytes_);
  for (long long first = 0; first < rows(); first += band) {
    const long long count = std::min(band, rows() - first);
    body(transposed_ ? a_.Read(0, a_.rows(), first, count) : a_.Read(first, count, 0, a_.columns()), first, count);
  }
}

void ForEachRowBlock(const StreamedMatrix& s, const ChannelWeights& weights,
                     const std::function<void(int, long long, const MatrixXd&)>& body) {
  const long long block = ProductBlockRows(s.columns());
  s.ForEachBand([&](const MatrixBlock& band, long long band_first, long long count) {
    const long long blocks = (count + block - 1) / block;
    tbb::parallel_for(tbb::blocked_range<long long>(0, 3 * blocks, 1), [&](const tbb::blocked_range<long long>& range) {
      MatrixXd a;
      for (long long t = range.begin(); t < range.end(); ++t) {
        const int ch = static_cast<int>(t / blocks);
        const long long first = (t % blocks) * block;
        s.Fill(band, first, std::min(block, count - first), weights[ch], &a);
        body(ch, band_first + first, a);
      }
    });
  });
}

void ForEachProduct(const StreamedMatrix& s, const ChannelWeights& weights, const std::array<MatrixXd, 3>& right,
                    const std::function<void(int, long long, const MatrixXd&)>& sink) {
  ForEachRowBlock(s, weights, [&](int ch, long long first, const MatrixXd& a) { sink(ch, first, a * right[ch]); });
}

std::array<MatrixXd, 3> TransposedProducts(const StreamedMatrix& s, const ChannelWeights& weights,
                                           const std::array<MatrixXd, 3>& left) {
  constexpr long long kChunks = 8;
  const long long n = s.columns();
  std::vector<MatrixXd> partial(3 * kChunks);
  for (long long t = 0; t < 3 * kChunks; ++t) partial[t] = MatrixXd::Zero(n, left[t / kChunks].cols());
  const long long block = ProductBlockRows(n);
  s.ForEachBand([&](const MatrixBlock& band, long long band_first, long long count) {
    const long long chunk = (count + kChunks - 1) / kChunks;
    tbb::parallel_for(tbb::blocked_range<long long>(0, 3 * kChunks, 1),
                      [&](const tbb::blocked_range<long long>& range) {
                        MatrixXd a;
                        for (long long t = range.begin(); t < range.end(); ++t) {
                          const int ch = static_cast<int>(t / kChunks);
                          const long long begin = (t % kChunks) * chunk, end = std::min(count, begin + chunk);
                          for (long long first = begin; first < end; first += block) {
                            const long long rows = std::min(block, end - first);
                            s.Fill(band, first, rows, weights[ch], &a);
                            partial[t].noalias() += a.transpose() * left[ch].middleRows(band_first + first, rows);
                          }
                        }
                      });
  });
  std::array<MatrixXd, 3> out;
  for (int ch = 0; ch < 3; ++ch) {
    out[ch] = std::move(partial[ch * kChunks]);
    for (long long c = 1; c < kChunks; ++c) out[ch] += partial[ch * kChunks + c];
  }
  return out;
}

}  // namespace mesocap::btf::compression
