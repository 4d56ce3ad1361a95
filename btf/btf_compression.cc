#include "btf/btf_compression.h"

#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/LU>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <random>
#include <sstream>

namespace mesocap::btf {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// The exact SVD (TSQR, O(m n^2) and n^2 doubles per channel) up to this many
// columns of the streamed matrix; the randomized one beyond (auto).
constexpr long long kMaxExactSvdColumns = 2048;
// Sketch columns beyond the largest rank kept (Halko et al. 2011 Sec. 4.2).
constexpr long long kRandomizedOversampling = 10;
// Up to this many bytes of float RGB a BTF is held in memory where it is
// read many times (a choice of representation, the clustered layout).
constexpr long long kMaxInMemoryBtfBytes = 2LL << 30;

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
  MatrixBlock Read(long long first_row, long long rows, long long first_column, long long columns) const {
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

 private:
  core::FullBtfReader& btf_;
  core::BtfFactorLayout layout_;
  long long rows_ = 0;
  long long columns_ = 0;
};

// Row bands of A: whole texture lines, all columns, about `bytes` of floats.
long long RowBandRows(const BtfMatrix& a, long long bytes) {
  const long long line = static_cast<long long>(a.width()) * a.columns() * 3 * sizeof(float);
  return a.width() * std::max<long long>(1, bytes / line);
}

// Column bands of A: whole columns, all rows.
long long ColumnBandColumns(const BtfMatrix& a, long long bytes) {
  return std::max<long long>(1, bytes / (a.rows() * 3 * static_cast<long long>(sizeof(float))));
}

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
  void ForEachBand(const std::function<void(const MatrixBlock&, long long, long long)>& body) const {
    const long long band = transposed_ ? ColumnBandColumns(a_, band_bytes_) : RowBandRows(a_, band_bytes_);
    for (long long first = 0; first < rows(); first += band) {
      const long long count = std::min(band, rows() - first);
      body(transposed_ ? a_.Read(0, a_.rows(), first, count) : a_.Read(first, count, 0, a_.columns()), first, count);
    }
  }
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

// Row-block sizes inside a band: about 2 MiB of doubles per block, never
// fewer rows than columns; a fixed number of blocks per parallel chunk, so
// the result does not depend on the thread count.
long long BlockRows(long long n) { return std::max<long long>(n, (1 << 18) / std::max<long long>(n, 1)); }
constexpr long long kBlocksPerChunk = 8;
// Row blocks of the passes that only multiply (no QR): about 2 MiB of
// doubles, and at least 256 rows, so that each block's product reuses the
// other factor (n x l, megabytes on a wide matrix) instead of streaming it
// from memory for a few rows.
long long ProductBlockRows(long long n) { return std::max<long long>(256, (1 << 18) / std::max<long long>(n, 1)); }

// R of the Householder QR of [top; block] (top may be empty): at most n rows,
// upper trapezoidal.
MatrixXd StackedR(const MatrixXd& top, const MatrixXd& block) {
  MatrixXd stacked(top.rows() + block.rows(), block.cols());
  stacked << top, block;
  Eigen::HouseholderQR<MatrixXd> qr(stacked);
  const long long k = std::min<long long>(stacked.rows(), stacked.cols());
  return qr.matrixQR().topRows(k).triangularView<Eigen::Upper>();
}

using ChannelWeights = std::array<Eigen::Vector3d, 3>;

// The R factors of the three channels' streamed matrices (TSQR): in each
// band, every chunk of blocks is reduced to its own R in parallel; the
// chunks' R are then stacked onto the running R in order.
std::array<MatrixXd, 3> TallSkinnyR(const StreamedMatrix& s, const ChannelWeights& weights) {
  const long long n = s.columns();
  const long long block = BlockRows(n);
  const long long chunk = block * kBlocksPerChunk;
  std::array<MatrixXd, 3> r;
  for (MatrixXd& c : r) c.resize(0, n);
  s.ForEachBand([&](const MatrixBlock& band, long long, long long count) {
    const long long chunks = (count + chunk - 1) / chunk;
    std::vector<MatrixXd> chunk_r(3 * chunks);
    tbb::parallel_for(tbb::blocked_range<long long>(0, 3 * chunks, 1), [&](const tbb::blocked_range<long long>& range) {
      MatrixXd a;
      for (long long t = range.begin(); t < range.end(); ++t) {
        const int ch = static_cast<int>(t / chunks);
        const long long c = t % chunks;
        MatrixXd rc(0, n);
        const long long end = std::min(count, (c + 1) * chunk);
        for (long long first = c * chunk; first < end; first += block) {
          s.Fill(band, first, std::min(block, end - first), weights[ch], &a);
          rc = StackedR(rc, a);
        }
        chunk_r[t] = std::move(rc);
      }
    });
    for (int ch = 0; ch < 3; ++ch)
      for (long long c = 0; c < chunks; ++c) r[ch] = StackedR(r[ch], chunk_r[ch * chunks + c]);
  });
  return r;
}

struct ChannelSvd {
  VectorXd sigma;  // min(rows, n), descending
  MatrixXd right;  // n x min(rows, n): right singular vectors of the streamed matrix
};

// Singular values and right singular vectors of the three channels'
// streamed matrices: one pass over the BTF, then the SVD of each small R.
std::array<ChannelSvd, 3> TallSkinnySvd(const StreamedMatrix& s, const ChannelWeights& weights) {
  const std::array<MatrixXd, 3> r = TallSkinnyR(s, weights);
  std::array<ChannelSvd, 3> out;
  for (int ch = 0; ch < 3; ++ch) {
    Eigen::BDCSVD<MatrixXd> svd(r[ch], Eigen::ComputeThinV);
    out[ch].sigma = svd.singularValues();
    out[ch].right = svd.matrixV();
  }
  return out;
}

// One pass over the row blocks of the streamed matrix S, every channel:
// body(ch, first_row, block) runs in parallel, each call for its own rows.
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

// One pass computing S(rows, :) * right[ch] for every row block of the
// streamed matrix S and channel; sink(ch, first_row, product) runs in
// parallel, each call for its own rows.
void ForEachProduct(const StreamedMatrix& s, const ChannelWeights& weights, const std::array<MatrixXd, 3>& right,
                    const std::function<void(int, long long, const MatrixXd&)>& sink) {
  ForEachRowBlock(s, weights, [&](int ch, long long first, const MatrixXd& a) { sink(ch, first, a * right[ch]); });
}

// S^T * left[ch] (left: S's rows x l) per channel in one pass. Each band's
// rows are split into a fixed number of chunks per channel, each chunk adding
// into its own partial sum across the bands; the partials are summed in
// chunk order at the end, so the result does not depend on the thread count.
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

// An orthonormal basis of the columns of y (thin Householder Q; columns past
// y's rank are completed to an orthonormal set, so rank-deficient sketches
// are fine).
MatrixXd OrthonormalBasis(const MatrixXd& y) {
  Eigen::HouseholderQR<MatrixXd> qr(y);
  return qr.householderQ() * MatrixXd::Identity(y.rows(), y.cols());
}

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
                                        int power_iterations, std::array<double, 3>* energy) {
  const long long m = s.rows(), n = s.columns();
  std::mt19937_64 random(20051);
  std::normal_distribution<double> normal;
  MatrixXd omega(n, components);
  for (long long j = 0; j < components; ++j)
    for (long long i = 0; i < n; ++i) omega(i, j) = normal(random);
  std::array<MatrixXd, 3> y;
  for (MatrixXd& c : y) c.resize(m, components);
  // Each block's energy at its first row, summed in row order afterwards
  // (independent of the thread count).
  std::vector<double> energy_at_row(static_cast<std::size_t>(3 * m), 0.0);
  ForEachRowBlock(s, weights, [&](int ch, long long first, const MatrixXd& a) {
    y[ch].middleRows(first, a.rows()).noalias() = a * omega;
    energy_at_row[static_cast<std::size_t>(ch * m + first)] = a.squaredNorm();
  });
  for (int ch = 0; ch < 3; ++ch) {
    (*energy)[ch] = 0.0;
    for (long long i = 0; i < m; ++i) (*energy)[ch] += energy_at_row[static_cast<std::size_t>(ch * m + i)];
  }
  std::array<MatrixXd, 3> q;
  for (int ch = 0; ch < 3; ++ch) q[ch] = OrthonormalBasis(y[ch]);
  for (int round = 0; round < power_iterations; ++round) {
    std::array<MatrixXd, 3> z = TransposedProducts(s, weights, q);
    for (int ch = 0; ch < 3; ++ch) z[ch] = OrthonormalBasis(z[ch]);
    ForEachProduct(s, weights, z, [&](int ch, long long first, const MatrixXd& product) {
      y[ch].middleRows(first, product.rows()) = product;
    });
    for (int ch = 0; ch < 3; ++ch) q[ch] = OrthonormalBasis(y[ch]);
  }
  const std::array<MatrixXd, 3> bt = TransposedProducts(s, weights, q);
  std::array<ChannelSvd, 3> out;
  for (int ch = 0; ch < 3; ++ch) {
    Eigen::BDCSVD<MatrixXd> svd(bt[ch], Eigen::ComputeThinU);
    out[ch].sigma = svd.singularValues();
    out[ch].right = svd.matrixU();
  }
  return out;
}

// Relative error at every rank from a truncated spectrum (randomized SVD):
// the tail is the channels' energy ||S||_F^2 minus the leading sigma^2,
// exact up to cancellation, so errors below ~1e-8 read as 0 here.
std::vector<double> TruncatedSpectrumErrors(const std::array<VectorXd, 3>& sigma, const std::array<double, 3>& energy,
                                            int max_rank) {
  double total = 0.0;
  for (const double e : energy) total += e;
  std::vector<double> errors(max_rank, 0.0);
  if (!(total > 0.0)) return errors;
  for (int k = 1; k <= max_rank; ++k) {
    double leading = 0.0;
    for (const VectorXd& s : sigma) leading += s.head(std::min<long long>(k, s.size())).squaredNorm();
    errors[k - 1] = std::sqrt(std::max(0.0, total - leading) / total);
  }
  return errors;
}

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

std::string Percent(double relative) {
  std::ostringstream s;
  s.precision(3);
  s << relative * 100.0 << "%";
  return s.str();
}

// The rank of the factorization from a spectrum's report `r`: as requested
// (at most the matrix's), or the smallest whose spectrum error meets the
// budget; says why in *reason.
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

// The factors of rank k from the channel SVDs: one pass over the BTF for the
// factor the SVD of R does not give.
struct FactorsFromSvd {
  const StreamedMatrix& s;
  const ChannelWeights& weights;
  const std::array<ChannelSvd, 3>& svd;
  bool tall = true;
  long long m = 0;
  long long n = 0;
  long long small = 0;

  void Build(int k, core::FactoredBtf* factored) const {
    core::FactoredBtf& out = *factored;
    out.rows.assign(k, core::Image(out.width, out.row_image_height(), 3));
    out.columns = core::Image(static_cast<int>(n), k, 3);
    std::array<MatrixXd, 3> right;
    std::array<int, 3> usable{};
    for (int ch = 0; ch < 3; ++ch) {
      const ChannelSvd& c = svd[ch];
      usable[ch] = static_cast<int>(std::min<long long>(k, c.sigma.size()));
      right[ch] = c.right.leftCols(usable[ch]);
    }
    // Numerically zero components (exactly rank-deficient data, a zero
    // channel): their share of A is rounding noise.
    const auto zero = [&](int ch, int j) {
      const VectorXd& sigma = svd[ch].sigma;
      return !(sigma[j] > static_cast<double>(small) * std::numeric_limits<double>::epsilon() * sigma[0]);
    };
    if (tall) {
      for (int ch = 0; ch < 3; ++ch)
        for (int j = 0; j < usable[ch]; ++j)
          for (long long c = 0; c < n; ++c)
            out.columns.pixel(static_cast<int>(c), j)[ch] = static_cast<float>(right[ch](c, j));
      // r_k = A v_k, from the data (see the header).
      ForEachProduct(s, weights, right, [&](int ch, long long first, const MatrixXd& rv) {
        for (int j = 0; j < usable[ch]; ++j) {
          float* dst = out.rows[j].data() + 3 * first + ch;
          for (long long i = 0; i < rv.rows(); ++i) dst[3 * i] = static_cast<float>(rv(i, j));
        }
      });
    } else {
      for (int ch = 0; ch < 3; ++ch) {
        for (int j = 0; j < usable[ch]; ++j) {
          if (zero(ch, j)) continue;
          float* dst = out.rows[j].data() + ch;
          for (long long i = 0; i < m; ++i) dst[3 * i] = static_cast<float>(svd[ch].sigma[j] * right[ch](i, j));
        }
      }
      // c_k = A^T u_k / sigma_k.
      ForEachProduct(s, weights, right, [&](int ch, long long first, const MatrixXd& au) {
        for (int j = 0; j < usable[ch]; ++j) {
          if (zero(ch, j)) continue;
          for (long long i = 0; i < au.rows(); ++i) {
            out.columns.pixel(static_cast<int>(first + i), j)[ch] = static_cast<float>(au(i, j) / svd[ch].sigma[j]);
          }
        }
      });
    }
  }
};

// A factored BTF of `btf`'s size and sets in a representation, no factors yet.
core::FactoredBtf NoFactors(const core::FullBtfReader& btf, core::BtfFactorLayout layout, core::BtfFactorColor color) {
  core::FactoredBtf out;
  out.width = btf.width();
  out.height = btf.height();
  out.views = btf.views();
  out.lights = btf.lights();
  out.layout = layout;
  out.color = color;
  out.rgb_to_factored =
      color == core::BtfFactorColor::kYCbCr ? core::YCbCrFromLinearRgbBt601() : Eigen::Matrix3d::Identity();
  return out;
}

// Each factored channel as weights of R, G and B: the rows of rgb_to_factored.
ChannelWeights FactoredChannelWeights(const core::FactoredBtf& f) {
  ChannelWeights weights;
  for (int ch = 0; ch < 3; ++ch) weights[ch] = f.rgb_to_factored.row(ch).transpose();
  return weights;
}

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

// Builds the factors at the rank the options give or the spectrum chooses,
// measures their RGB error, and fills in the rank and bytes. The budget is on
// RGB values; for ycbcr the spectrum measures the error in the factored
// space, so the rank grows until the measured RGB error fits (for rgb only
// float rounding could make it grow).
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

// The SVD of one representation's matrix (paper or per_texel layout) and
// what it needs to build factors: the matrix view of the BTF, kept in place
// because the streamed matrix refers to it.
struct GlobalSvd {
  GlobalSvd(core::FullBtfReader& btf, core::BtfFactorLayout layout, long long band_bytes)
      : a(btf, layout), s(a, a.rows() < a.columns(), band_bytes) {}
  GlobalSvd(const GlobalSvd&) = delete;
  GlobalSvd& operator=(const GlobalSvd&) = delete;

  BtfMatrix a;
  StreamedMatrix s;
  ChannelWeights weights;
  std::array<ChannelSvd, 3> svd;
};

// The SVD of one representation in the paper or per_texel layout, the rank
// as options.rank or left to options.max_relative_error (max_bytes is turned
// into a rank by the caller).
Factorization FactorOneRepresentation(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                                      core::BtfFactorLayout layout, core::BtfFactorColor color) {
  Factorization f;
  f.shape = NoFactors(btf, layout, color);
  auto state = std::make_shared<GlobalSvd>(btf, layout, options.band_bytes);
  state->weights = FactoredChannelWeights(f.shape);
  const long long m = state->a.rows(), n = state->a.columns();
  const bool tall = m >= n;
  const long long small = std::min(m, n);
  // The SVD of A (tall) or of A^T (wide); `right` then holds the right
  // singular vectors of A (tall) or its left ones (wide).
  const bool randomized =
      options.svd == BtfSvdMethod::kRandomized || (options.svd == BtfSvdMethod::kAuto && small > kMaxExactSvdColumns);
  // The randomized SVD sketches only the ranks it may need: a fixed rank's
  // (the error per rank is then known up to it), or every rank a budget
  // may choose.
  const int max_rank =
      static_cast<int>(std::min<long long>(randomized && options.rank > 0 ? options.rank : core::kMaxBtfRank, small));
  std::array<double, 3> energy{};
  state->svd = randomized ? RandomizedSvd(state->s, state->weights,
                                          std::min<long long>(small, max_rank + kRandomizedOversampling),
                                          options.power_iterations, &energy)
                          : TallSkinnySvd(state->s, state->weights);

  BtfCompressionReport& r = f.report;
  for (int ch = 0; ch < 3; ++ch) r.singular_values[ch] = state->svd[ch].sigma;
  r.max_rank = max_rank;
  r.matrix_rows = m;
  r.matrix_columns = n;
  r.relative_rms_error = randomized ? TruncatedSpectrumErrors(r.singular_values, energy, r.max_rank)
                                    : SpectrumErrors(r.singular_values, r.max_rank);
  r.svd = randomized ? "randomized (" + std::to_string(state->svd[0].sigma.size()) + " components, " +
                           std::to_string(options.power_iterations) + " power iterations)"
                     : "exact";
  f.build = [state, tall, m, n, small](int k, core::FactoredBtf* out) {
    FactorsFromSvd{state->s, state->weights, state->svd, tall, m, n, small}.Build(k, out);
  };
  return f;
}

// Clustered local PCA (Mueller et al. 2003): the texels are grouped by
// k-means (OpenCV) on their apparent BRDFs, and each cluster's texels x
// (view, light) matrix gets its own SVD, one rank for all clusters. The
// features are the texels' values projected to kClusterFeatures dimensions
// by a fixed random Gaussian matrix, which keeps distances to a few percent
// (Johnson-Lindenstrauss) at a fraction of k-means' cost. Each cluster's SVD
// is taken of its matrix (QrSvd), not of A^T A, so its spectrum is accurate
// to rounding. The whole BTF is in memory (float), read in place.
constexpr int kClusterFeatures = 128;
// Texels per task when the features are computed: a few MiB of one
// channel's rows.
constexpr long long kFeatureTexels = 256;

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

TruncatedSvd QrSvd(const MatrixXd& a, long long keep) {
  const bool wide = a.cols() > a.rows();
  Eigen::HouseholderQR<MatrixXd> qr;
  if (wide) {
    qr.compute(a.transpose());
  } else {
    qr.compute(a);
  }
  const long long tall_rows = qr.matrixQR().rows(), s = qr.matrixQR().cols();
  const MatrixXd r = qr.matrixQR().topRows(s).triangularView<Eigen::Upper>();
  Eigen::BDCSVD<MatrixXd> svd(r, Eigen::ComputeThinU | Eigen::ComputeThinV);
  keep = std::min(keep, s);
  // t = (Q Ur) S Vr^T: its left vectors Q Ur, its right ones Vr.
  MatrixXd q_ur = MatrixXd::Zero(tall_rows, keep);
  q_ur.topRows(s) = svd.matrixU().leftCols(keep);
  q_ur.applyOnTheLeft(qr.householderQ());
  const auto sigma = svd.singularValues().head(keep).asDiagonal();
  TruncatedSvd out;
  out.sigma = svd.singularValues();
  if (wide) {  // a = t^T = Vr S (Q Ur)^T
    out.left_scaled = svd.matrixV().leftCols(keep) * sigma;
    out.right = std::move(q_ur);
  } else {
    out.left_scaled = q_ur * sigma;
    out.right = svd.matrixV().leftCols(keep);
  }
  return out;
}

struct ClusteredSvd {
  int clusters = 0;
  std::vector<int> texel_clusters;
  std::vector<std::vector<long long>> members;  // texel indices of each cluster
  // Per cluster and channel: U * Sigma (members x kept) and V (n x kept),
  // kept up to kMaxBtfRank columns, in float as the factors are stored (at
  // 128 clusters of a paper-rig BTF, V alone is 128 x 3 x 9216 x 100).
  std::vector<std::array<Eigen::MatrixXf, 3>> left, right;
  std::vector<VectorXd> spectra;  // every cluster's and channel's singular values
};

ClusteredSvd ClusterAndFactor(const core::FullBtf& btf, const ChannelWeights& weights, int clusters) {
  const int w = btf.width, h = btf.height, nl = btf.light_count(), nv = btf.view_count();
  const long long texels = static_cast<long long>(w) * h;
  const long long n = static_cast<long long>(nv) * nl;
  // Texel p's value in column (view, light) of channel ch.
  const auto value = [&](int ch, long long p, int v, int l) {
    const float* rgb = btf.view_images[v].pixel(static_cast<int>(p % w), l * h + static_cast<int>(p / w));
    return weights[ch][0] * rgb[0] + weights[ch][1] * rgb[1] + weights[ch][2] * rgb[2];
  };
  // Rows [first, first + count) of channel ch's texels x (view, light) matrix.
  const auto texel_rows = [&](int ch, long long first, long long count, Eigen::MatrixXf* out) {
    out->resize(count, n);
    for (int v = 0; v < nv; ++v)
      for (int l = 0; l < nl; ++l)
        for (long long i = 0; i < count; ++i)
          (*out)(i, static_cast<long long>(v) * nl + l) = value(ch, first + i, v, l);
  };
  using RowMajor = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const bool project = 3 * n > kClusterFeatures;
  std::array<Eigen::MatrixXf, 3> projection;
  if (project) {
    std::mt19937 rng(20031);
    std::normal_distribution<float> gauss(0.0f, 1.0f / std::sqrt(static_cast<float>(kClusterFeatures)));
    for (Eigen::MatrixXf& p : projection) {
      p.resize(n, kClusterFeatures);
      for (long long i = 0; i < p.size(); ++i) p.data()[i] = gauss(rng);
    }
  }
  RowMajor features(texels, project ? kClusterFeatures : 3 * n);
  const long long chunks = (texels + kFeatureTexels - 1) / kFeatureTexels;
  tbb::parallel_for(0LL, chunks, [&](long long c) {
    const long long first = c * kFeatureTexels, count = std::min(kFeatureTexels, texels - first);
    Eigen::MatrixXf rows;
    auto out = features.middleRows(first, count);
    if (project) out.setZero();
    for (int ch = 0; ch < 3; ++ch) {
      texel_rows(ch, first, count, &rows);
      if (project) {
        out.noalias() += rows * projection[ch];
      } else {
        out.middleCols(ch * n, n) = rows;
      }
    }
  });
  ClusteredSvd out;
  const int k = static_cast<int>(std::min<long long>(clusters, texels));
  cv::Mat labels;
  if (k > 1) {
    const cv::Mat data(static_cast<int>(texels), static_cast<int>(features.cols()), CV_32F, features.data());
    cv::setRNGSeed(20031);  // OpenCV's k-means++ seeding draws from the thread's RNG
    cv::kmeans(data, k, labels, cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-6), 1,
               cv::KMEANS_PP_CENTERS);
  } else {
    labels = cv::Mat::zeros(static_cast<int>(texels), 1, CV_32S);
  }
  // Clusters numbered by first texel, empty ones dropped.
  std::vector<int> renumber(k, -1);
  out.texel_clusters.resize(texels);
  for (long long p = 0; p < texels; ++p) {
    int& c = renumber[labels.at<int>(static_cast<int>(p))];
    if (c < 0) {
      c = out.clusters++;
      out.members.emplace_back();
    }
    out.texel_clusters[p] = c;
    out.members[c].push_back(p);
  }
  out.left.resize(out.clusters);
  out.right.resize(out.clusters);
  out.spectra.resize(3 * static_cast<std::size_t>(out.clusters));
  tbb::parallel_for(0, 3 * out.clusters, [&](int t) {
    const int c = t / 3, ch = t % 3;
    const std::vector<long long>& m = out.members[c];
    MatrixXd a(static_cast<long long>(m.size()), n);
    for (int v = 0; v < nv; ++v)
      for (int l = 0; l < nl; ++l)
        for (std::size_t i = 0; i < m.size(); ++i)
          a(static_cast<long long>(i), static_cast<long long>(v) * nl + l) = static_cast<float>(value(ch, m[i], v, l));
    TruncatedSvd svd = QrSvd(a, core::kMaxBtfRank);
    out.spectra[t] = std::move(svd.sigma);
    out.left[c][ch] = svd.left_scaled.cast<float>();
    out.right[c][ch] = svd.right.cast<float>();
  });
  return out;
}

// The clustered layout's k-means and per-cluster SVDs at `clusters`
// clusters; each cluster's factors are kept up to the largest rank a budget
// may choose.
Factorization FactorClustered(const core::FullBtf& btf, int clusters, core::BtfFactorColor color) {
  Factorization f;
  f.shape = NoFactors(core::InMemoryFullBtfReader(btf), core::BtfFactorLayout::kClustered, color);
  const long long n = static_cast<long long>(f.shape.view_count()) * f.shape.light_count();
  auto svd = std::make_shared<ClusteredSvd>(ClusterAndFactor(btf, FactoredChannelWeights(f.shape), clusters));
  f.shape.cluster_count = svd->clusters;
  f.shape.texel_clusters = svd->texel_clusters;

  BtfCompressionReport& r = f.report;
  long long largest = 0;
  for (const auto& members : svd->members) largest = std::max<long long>(largest, members.size());
  r.max_rank = static_cast<int>(
      std::min<long long>({core::kMaxBtfRank, std::min(largest, n), core::kMaxBtfColumnRows / svd->clusters}));
  r.matrix_rows = static_cast<long long>(f.shape.width) * f.shape.height;
  r.matrix_columns = n;
  r.relative_rms_error = SpectrumErrors(svd->spectra, r.max_rank);
  r.svd = "exact";
  for (int c = 0; c < svd->clusters; ++c) {
    for (int ch = 0; ch < 3; ++ch) {
      Eigen::MatrixXf& left = svd->left[c][ch];
      Eigen::MatrixXf& right = svd->right[c][ch];
      const long long kept = std::min<long long>(left.cols(), r.max_rank);
      left = left.leftCols(kept).eval();
      right = right.leftCols(kept).eval();
    }
  }
  f.build = [svd, n](int k, core::FactoredBtf* out) {
    out->rows.assign(k, core::Image(out->width, out->height, 3));
    out->columns = core::Image(static_cast<int>(n), k * svd->clusters, 3);
    for (int c = 0; c < svd->clusters; ++c) {
      for (int ch = 0; ch < 3; ++ch) {
        const Eigen::MatrixXf& left = svd->left[c][ch];
        const Eigen::MatrixXf& right = svd->right[c][ch];
        for (int j = 0; j < std::min<long long>(k, left.cols()); ++j) {
          for (std::size_t i = 0; i < svd->members[c].size(); ++i) {
            out->rows[j].data()[3 * svd->members[c][i] + ch] = left(static_cast<long long>(i), j);
          }
          for (long long col = 0; col < n; ++col) {
            out->columns.pixel(static_cast<int>(col), c * k + j)[ch] = right(col, j);
          }
        }
      }
    }
  };
  return f;
}

// The per-view factorisation (Sattler et al. 2003): each view's texels x
// lights matrix A_v gets its own SVD, one rank for all views. A_v is tall
// (texels) and narrow (lights), so its SVD is taken directly (Eigen BDCSVD,
// accurate to rounding, not through A_v^T A_v). Only each view's right
// singular vectors (Nlight x K) are kept; the row factors A_v v_k are
// computed from the data when the factors are built, a second read of the
// views, so memory stays at one view per worker.
Factorization FactorPerView(core::FullBtfReader& btf, core::BtfFactorColor color) {
  Factorization f;
  f.shape = NoFactors(btf, core::BtfFactorLayout::kPerView, color);
  const int nv = btf.view_count(), nl = btf.light_count();
  // per_view's A is per_texel's texels x (view, light) matrix; view v's
  // matrix A_v is its block of columns [v * Nlight, (v + 1) * Nlight).
  const BtfMatrix a(btf, core::BtfFactorLayout::kPerView);
  const long long texels = a.rows();
  const ChannelWeights weights = FactoredChannelWeights(f.shape);
  const auto view_matrix = [a, weights, nl](int v, std::array<MatrixXd, 3>* out) {
    const MatrixBlock block = a.Read(0, a.rows(), static_cast<long long>(v) * nl, nl);
    for (int ch = 0; ch < 3; ++ch) block.FillRows(0, a.rows(), weights[ch], &(*out)[ch]);
  };
  BtfCompressionReport& r = f.report;
  r.max_rank = static_cast<int>(std::min<long long>(
      {core::kMaxBtfRank, std::min<long long>(texels, nl), core::kMaxBtfColumnRows / std::max(1, nv)}));
  r.matrix_rows = a.rows();
  r.matrix_columns = a.columns();
  r.svd = "exact";
  // Per view and channel: V truncated to max_rank columns; the spectra.
  auto right = std::make_shared<std::vector<std::array<MatrixXd, 3>>>(nv);
  std::vector<VectorXd> spectra(3 * static_cast<std::size_t>(nv));
  tbb::parallel_for(0, nv, [&](int v) {
    std::array<MatrixXd, 3> a;
    view_matrix(v, &a);
    for (int ch = 0; ch < 3; ++ch) {
      Eigen::BDCSVD<MatrixXd> svd(a[ch], Eigen::ComputeThinV);
      spectra[3 * v + ch] = svd.singularValues();
      (*right)[v][ch] = svd.matrixV().leftCols(std::min<long long>(svd.matrixV().cols(), r.max_rank));
    }
  });
  r.relative_rms_error = SpectrumErrors(spectra, r.max_rank);
  f.build = [right, view_matrix, texels, nv, nl](int k, core::FactoredBtf* out) {
    out->rows.assign(k, core::Image(out->width, out->row_image_height(), 3));
    out->columns = core::Image(nl, k * nv, 3);
    tbb::parallel_for(0, nv, [&](int v) {
      std::array<MatrixXd, 3> a;
      view_matrix(v, &a);
      for (int ch = 0; ch < 3; ++ch) {
        const MatrixXd& vectors = (*right)[v][ch];
        const long long usable = std::min<long long>(k, vectors.cols());
        const MatrixXd av = a[ch] * vectors.leftCols(usable);  // r_k = A_v v_k
        for (int j = 0; j < usable; ++j) {
          float* dst = out->rows[j].data() + 3 * v * texels + ch;
          for (long long p = 0; p < texels; ++p) dst[3 * p] = static_cast<float>(av(p, j));
          for (int l = 0; l < nl; ++l) out->columns.pixel(l, v * k + j)[ch] = static_cast<float>(vectors(l, j));
        }
      }
    });
  };
  return f;
}

std::string RepresentationName(core::BtfFactorLayout layout, core::BtfFactorColor color, int clusters) {
  return std::string(ToString(layout)) +
         (layout == core::BtfFactorLayout::kClustered ? "(" + std::to_string(clusters) + ")" : std::string()) + "/" +
         ToString(color);
}

std::string Bytes(long long bytes) {
  std::ostringstream s;
  s.precision(3);
  if (bytes < (1LL << 20)) {
    s << bytes / 1024.0 << " KiB";
  } else if (bytes < (1LL << 30)) {
    s << bytes / double(1LL << 20) << " MiB";
  } else {
    s << bytes / double(1LL << 30) << " GiB";
  }
  return s.str();
}

// Whether candidate c is a better pick than the best so far: with a byte
// budget the more accurate; with an error budget the smaller of those that
// meet it, else (none meets it) the more accurate.
bool Better(const BtfRepresentationCandidate& c, const BtfRepresentationCandidate& best, bool byte_budget) {
  if (byte_budget || (!c.meets_budget && !best.meets_budget)) {
    return c.relative_rms_error < best.relative_rms_error ||
           (c.relative_rms_error == best.relative_rms_error && c.factor_bytes < best.factor_bytes);
  }
  if (c.meets_budget != best.meets_budget) return c.meets_budget;
  return c.factor_bytes < best.factor_bytes ||
         (c.factor_bytes == best.factor_bytes && c.relative_rms_error < best.relative_rms_error);
}

}  // namespace

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

const char* ToString(BtfSvdMethod method) {
  switch (method) {
    case BtfSvdMethod::kAuto:
      return "auto";
    case BtfSvdMethod::kExact:
      return "exact";
    case BtfSvdMethod::kRandomized:
      return "randomized";
  }
  return "?";
}

BtfSvdMethod ParseBtfSvdMethod(const std::string& name) {
  for (const BtfSvdMethod method : {BtfSvdMethod::kAuto, BtfSvdMethod::kExact, BtfSvdMethod::kRandomized}) {
    if (name == ToString(method)) return method;
  }
  throw core::Error("unknown SVD method " + core::Quoted(name) + " (expected auto, exact or randomized)");
}

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

namespace {

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

// CompressBtf over `btf`; `whole` is the same BTF in memory, or null where it
// is not held (then the clustered layout is not tried).
core::FactoredBtf Compress(core::FullBtfReader& btf, const core::FullBtf* whole, const BtfCompressionOptions& options,
                           BtfCompressionReport* report) {
  const auto start = std::chrono::steady_clock::now();
  BtfCompressionReport local;
  BtfCompressionReport& r = report ? *report : local;

  // The representations allowed: every layout and colour the options leave
  // open, the clustered layout at each cluster count; rgb first, whose
  // spectra settle their errors, so that a ycbcr representation that cannot
  // beat the best of them need not be built.
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
  const bool choosing = candidates.size() > 1;
  const bool byte_budget = options.max_bytes > 0;
  const long long texels = static_cast<long long>(btf.width()) * btf.height();
  const long long full_bytes = FullBtfBytes(btf);

  // Under an error budget, factors as large as the BTF itself compress
  // nothing: they do not count as meeting it.
  const auto judge = [&](BtfRepresentationCandidate& c) {
    c.meets_budget = byte_budget ? c.factor_bytes <= options.max_bytes
                                 : options.rank > 0 || (c.relative_rms_error <= options.max_relative_error &&
                                                        c.factor_bytes < full_bytes);
    if (!byte_budget && options.rank == 0 && c.relative_rms_error <= options.max_relative_error && !c.meets_budget) {
      c.note = "meets the error budget only in at least as many bytes as the full BTF (" + Bytes(full_bytes) + ")";
    }
  };
  // The best so far: its factors when they were built to settle its error,
  // else its SVD, built once the choice is made.
  core::FactoredBtf best;
  BtfCompressionReport best_report;
  std::optional<Factorization> best_unbuilt;
  BtfCompressionOptions best_options;
  int best_index = -1;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    BtfRepresentationCandidate& c = candidates[i];
    const std::string name = RepresentationName(c.layout, c.color, c.clusters);
    if (c.layout == core::BtfFactorLayout::kClustered && !whole) {
      c.note = "not tried: the clustered layout holds the whole BTF in memory, and this one is over " +
               Bytes(kMaxInMemoryBtfBytes);
      if (!choosing) throw core::Error("compress: " + name + " " + c.note);
      continue;
    }
    BtfCompressionOptions one = options;
    if (byte_budget) {
      const long long ids = c.layout == core::BtfFactorLayout::kClustered ? texels * 4 : 0;
      const long long per_rank =
          FactorBytes(c.layout, btf.width(), btf.height(), btf.view_count(), btf.light_count(), 1, c.clusters) - ids;
      one.rank = static_cast<int>(std::clamp<long long>((options.max_bytes - ids) / per_rank, 0, core::kMaxBtfRank));
      if (one.rank == 0) {
        c.factor_bytes = per_rank + ids;
        c.note = "not tried: rank 1 takes " + std::to_string(c.factor_bytes) + " bytes";
        if (!choosing) {
          throw core::Error("compress: max_bytes " + std::to_string(options.max_bytes) + " is less than rank 1 of " +
                            name + " (" + std::to_string(c.factor_bytes) + " bytes)");
        }
        continue;
      }
    }
    const auto factored_at = std::chrono::steady_clock::now();
    Factorization f = c.layout == core::BtfFactorLayout::kClustered ? FactorClustered(*whole, c.clusters, c.color)
                      : c.layout == core::BtfFactorLayout::kPerView
                          ? FactorPerView(btf, c.color)
                          : FactorOneRepresentation(btf, one, c.layout, c.color);
    c.clusters = f.shape.cluster_count;
    // A byte budget's rank, at most what this representation can hold (its
    // clusters' sizes, its rows of column factors).
    if (byte_budget) one.rank = std::min(one.rank, f.report.max_rank);
    std::string reason;
    c.rank = ChooseRank(one, c.color, f.report, &reason);
    c.factor_bytes = f.Bytes(c.rank);
    c.relative_rms_error = f.report.relative_rms_error[c.rank - 1];
    core::FactoredBtf built;
    BtfCompressionReport built_report;
    if (c.color != core::BtfFactorColor::kRgb) {
      // Under an error budget the rank only grows from the spectrum's while
      // the measured RGB error is over the budget: at least these bytes.
      const BtfRepresentationCandidate* leader = best_index >= 0 ? &candidates[best_index] : nullptr;
      if (choosing && !byte_budget && leader && leader->meets_budget && c.factor_bytes >= leader->factor_bytes) {
        c.note = "not built: its spectrum's rank " + std::to_string(c.rank) + " (" + Percent(c.relative_rms_error) +
                 " in Y, Cb, Cr) already takes " + Bytes(c.factor_bytes) + ", no less than " +
                 RepresentationName(leader->layout, leader->color, leader->clusters);
        continue;
      }
      built = BuildAtChosenRank(btf, one, f, built_report);
      c.rank = built_report.rank;
      c.factor_bytes = built_report.factor_bytes;
      c.relative_rms_error = built_report.measured_relative_rms_error;
      c.measured = true;
    }
    judge(c);
    spdlog::info("compress: {}: rank {}, {}, {} {}({:.1f} s)", name, c.rank, Bytes(c.factor_bytes),
                 Percent(c.relative_rms_error), c.measured ? "measured " : "from the spectrum ",
                 std::chrono::duration<double>(std::chrono::steady_clock::now() - factored_at).count());
    if (best_index < 0 || Better(c, candidates[best_index], byte_budget)) {
      best_index = static_cast<int>(i);
      best_options = one;
      if (c.measured) {
        best = std::move(built);
        best_report = std::move(built_report);
        best_unbuilt.reset();
      } else {
        best_unbuilt = std::move(f);
      }
    }
  }
  if (best_index >= 0 && best_unbuilt) {
    BtfRepresentationCandidate& c = candidates[best_index];
    best = BuildAtChosenRank(btf, best_options, *best_unbuilt, best_report);
    best_unbuilt.reset();
    c.rank = best_report.rank;
    c.factor_bytes = best_report.factor_bytes;
    c.relative_rms_error = best_report.measured_relative_rms_error;
    c.measured = true;
    judge(c);
  }
  if (best_index < 0) {
    throw core::Error(
        "compress: max_bytes " + std::to_string(options.max_bytes) +
        " is less than rank 1 of every representation (the smallest: " +
        std::to_string(std::min_element(candidates.begin(), candidates.end(),
                                        [](const auto& a, const auto& b) { return a.factor_bytes < b.factor_bytes; })
                           ->factor_bytes) +
        " bytes)");
  }
  if (!byte_budget && options.rank == 0 && !candidates[best_index].meets_budget && !choosing) {
    best_report.reason += candidates[best_index].note.empty() ? "" : "; " + candidates[best_index].note;
  }
  r = std::move(best_report);
  if (choosing) {
    const BtfRepresentationCandidate& c = candidates[best_index];
    const std::string name = RepresentationName(c.layout, c.color, c.clusters);
    const std::string figures =
        "rank " + std::to_string(c.rank) + ", " + Bytes(c.factor_bytes) + ", " + Percent(c.relative_rms_error);
    if (byte_budget) {
      r.representation_reason = name + ": the most accurate of " + std::to_string(candidates.size()) +
                                " representations within " + Bytes(options.max_bytes) + " (" + figures + ")";
    } else if (c.meets_budget) {
      r.representation_reason = name + ": the smallest of the representations that meet the budget " +
                                Percent(options.max_relative_error) + " (" + figures + ")";
    } else {
      r.representation_reason = name + ": no representation meets the budget " + Percent(options.max_relative_error) +
                                " in fewer bytes than the full BTF (" + Bytes(full_bytes) + ") up to rank " +
                                std::to_string(core::kMaxBtfRank) + "; the most accurate (" + figures + ")";
    }
    r.candidates = std::move(candidates);
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return best;
}

}  // namespace

core::FactoredBtf CompressBtf(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                              BtfCompressionReport* report) {
  if (const auto problem = options.Check(); !problem.empty()) throw core::Error("compress: " + problem);
  // A choice or the clustered layout makes many passes over the BTF (an SVD
  // and its factors per representation): below kMaxInMemoryBtfBytes it is
  // read once and held, rather than decoded from its files on every pass.
  const long long bytes = FullBtfBytes(btf);
  const bool many_passes = !options.layout || !options.color || *options.layout == core::BtfFactorLayout::kClustered;
  if (!many_passes || bytes > kMaxInMemoryBtfBytes) return Compress(btf, nullptr, options, report);
  core::CheckMemoryFor(bytes, "the " + std::to_string(btf.width()) + "x" + std::to_string(btf.height()) +
                                  " BTF held in memory while it is factored");
  const auto read_at = std::chrono::steady_clock::now();
  const core::FullBtf whole = HoldInMemory(btf);
  spdlog::info("compress: read the BTF into memory ({}) in {:.1f} s", Bytes(bytes),
               std::chrono::duration<double>(std::chrono::steady_clock::now() - read_at).count());
  core::InMemoryFullBtfReader reader(whole);
  return Compress(reader, &whole, options, report);
}

core::FactoredBtf CompressBtf(const core::FullBtf& btf, const BtfCompressionOptions& options,
                              BtfCompressionReport* report) {
  if (const auto problem = options.Check(); !problem.empty()) throw core::Error("compress: " + problem);
  core::InMemoryFullBtfReader reader(btf);
  if (!options.layout || *options.layout == core::BtfFactorLayout::kClustered) {
    // The clustered layout reads `btf` in place, past the reader's check
    // for non-finite values: that check runs here, a view at a time.
    std::vector<float> view(static_cast<std::size_t>(3) * btf.width * btf.height * btf.light_count());
    for (int v = 0; v < btf.view_count(); ++v) reader.ReadRows(v, 0, btf.height * btf.light_count(), view.data());
  }
  return Compress(reader, &btf, options, report);
}

nlohmann::json ToJson(const BtfCompressionReport& report, const core::FactoredBtf& factored) {
  const char* names[2][3] = {{"r", "g", "b"}, {"y", "cb", "cr"}};
  nlohmann::json spectrum = nlohmann::json::object();
  for (int ch = 0; ch < 3; ++ch) {
    const Eigen::VectorXd& s = report.singular_values[ch];
    spectrum[names[factored.color == core::BtfFactorColor::kYCbCr][ch]] =
        std::vector<double>(s.data(), s.data() + s.size());
  }
  nlohmann::json candidates = nlohmann::json::array();
  for (const BtfRepresentationCandidate& c : report.candidates) {
    nlohmann::json one = {{"layout", ToString(c.layout)},
                          {"color", ToString(c.color)},
                          {"rank", c.rank},
                          {"factor_bytes", c.factor_bytes},
                          {"relative_rms", c.relative_rms_error},
                          {"error_from", c.measured                              ? "measured"
                                         : c.color == core::BtfFactorColor::kRgb ? "spectrum"
                                                                                 : "spectrum in Y, Cb, Cr"},
                          {"meets_budget", c.meets_budget}};
    if (c.layout == core::BtfFactorLayout::kClustered) one["clusters"] = c.clusters;
    if (!c.note.empty()) one["note"] = c.note;
    candidates.push_back(std::move(one));
  }
  nlohmann::json out = {{"layout", ToString(factored.layout)},
                        {"color", ToString(factored.color)},
                        {"rank", report.rank},
                        {"reason", report.reason},
                        {"measured_relative_rms", report.measured_relative_rms_error},
                        {"factor_bytes", report.factor_bytes},
                        {"relative_rms_by_rank", report.relative_rms_error},
                        {"max_rank", report.max_rank},
                        {"matrix_size", {report.matrix_rows, report.matrix_columns}},
                        {"svd", report.svd},
                        {"singular_values", spectrum},
                        {"seconds", report.seconds}};
  if (factored.layout == core::BtfFactorLayout::kClustered) out["clusters"] = factored.cluster_count;
  if (!report.candidates.empty()) {
    out["representation_reason"] = report.representation_reason;
    out["candidates"] = std::move(candidates);
  }
  return out;
}

core::Image ReconstructBtfView(const core::FactoredBtf& f, int view) {
  f.CheckShape();
  if (view < 0 || view >= f.view_count())
    throw core::Error("factored BTF: view " + std::to_string(view) + " out of range");
  Eigen::Matrix3d to_rgb = Eigen::Matrix3d::Identity();
  if (f.color == core::BtfFactorColor::kYCbCr) to_rgb = f.rgb_to_factored.inverse();
  const int nl = f.light_count();
  const long long texels = static_cast<long long>(f.width) * f.height;
  core::Image out(f.width, f.height * nl, 3);
  std::vector<double> acc(3 * texels);
  for (int l = 0; l < nl; ++l) {
    std::fill(acc.begin(), acc.end(), 0.0);
    // paper: rows (x, y, light), column view; per_view: rows (x, y) of the
    // view's images, column light; per_texel: rows (x, y), column
    // view * Nlight + light.
    const bool paper = f.layout == core::BtfFactorLayout::kPaper;
    const bool per_view = f.layout == core::BtfFactorLayout::kPerView;
    const int column = paper ? view : per_view ? l : view * nl + l;
    const long long offset = paper ? 3 * l * texels : per_view ? 3 * view * texels : 0;
    const bool clustered = f.layout == core::BtfFactorLayout::kClustered;
    for (int k = 0; k < f.rank(); ++k) {
      const float* r = f.rows[k].data() + offset;
      const int set_row = per_view ? view * f.rank() + k : k;
      for (long long i = 0; i < texels; ++i) {
        const float* c = f.columns.pixel(column, clustered ? f.texel_clusters[i] * f.rank() + k : set_row);
        for (int ch = 0; ch < 3; ++ch) acc[3 * i + ch] += static_cast<double>(r[3 * i + ch]) * c[ch];
      }
    }
    float* dst = out.pixel(0, l * f.height);
    for (long long i = 0; i < texels; ++i) {
      const Eigen::Vector3d rgb = to_rgb * Eigen::Vector3d(acc[3 * i], acc[3 * i + 1], acc[3 * i + 2]);
      for (int ch = 0; ch < 3; ++ch) dst[3 * i + ch] = static_cast<float>(rgb[ch]);
    }
  }
  return out;
}

double RelativeRmsError(core::FullBtfReader& truth, const core::FactoredBtf& factored, long long band_bytes) {
  factored.CheckShape();
  if (truth.width() != factored.width || truth.height() != factored.height ||
      truth.view_count() != factored.view_count() || truth.light_count() != factored.light_count()) {
    throw core::Error("relative error: the BTF and its factors differ in size");
  }
  Eigen::Matrix3d to_rgb = Eigen::Matrix3d::Identity();
  if (factored.color == core::BtfFactorColor::kYCbCr) to_rgb = factored.rgb_to_factored.inverse();
  const BtfMatrix a(truth, factored.layout);
  const long long n = a.columns();
  const int k = factored.rank();
  // Column factors per set (a cluster's, a view's, or the one set) and
  // channel, column_count() x K. per_view's matrix A is per_texel's, each
  // view's block of Nlight columns from its own factors.
  const bool clustered = factored.layout == core::BtfFactorLayout::kClustered;
  const bool per_view = factored.layout == core::BtfFactorLayout::kPerView;
  const long long texels = static_cast<long long>(factored.width) * factored.height;
  const int set_columns = factored.column_count();
  std::vector<std::array<MatrixXd, 3>> columns(factored.column_sets());
  for (std::size_t set = 0; set < columns.size(); ++set) {
    for (int ch = 0; ch < 3; ++ch) {
      MatrixXd& out = columns[set][ch];
      out.resize(set_columns, k);
      for (int j = 0; j < k; ++j) {
        for (int c = 0; c < set_columns; ++c) {
          out(c, j) = factored.columns.pixel(c, static_cast<int>(set) * k + j)[ch];
        }
      }
    }
  }
  // Per row block, summed in block order so the result does not depend on
  // the thread count.
  const long long block = ProductBlockRows(n);
  std::vector<double> error, norm;
  StreamedMatrix(a, false, band_bytes).ForEachBand([&](const MatrixBlock& band, long long band_first, long long count) {
    const long long blocks = (count + block - 1) / block;
    const std::size_t offset = error.size();
    error.resize(offset + blocks, 0.0);
    norm.resize(offset + blocks, 0.0);
    tbb::parallel_for(tbb::blocked_range<long long>(0, blocks, 1), [&](const tbb::blocked_range<long long>& range) {
      for (long long b = range.begin(); b < range.end(); ++b) {
        const long long first = b * block;
        const long long rows_here = std::min(block, count - first);
        std::array<MatrixXd, 3> recon, value;
        for (int ch = 0; ch < 3; ++ch) {
          MatrixXd rows(rows_here, k);
          for (int j = 0; j < k; ++j) {
            const float* src = factored.rows[j].data() + 3 * (band_first + first) + ch;
            for (long long i = 0; i < rows_here; ++i) rows(i, j) = src[3 * i];
          }
          if (clustered) {
            recon[ch].resize(rows_here, n);
            for (long long i = 0; i < rows_here; ++i) {
              const int cluster = factored.texel_clusters[band_first + first + i];
              recon[ch].row(i).noalias() = rows.row(i) * columns[cluster][ch].transpose();
            }
          } else if (per_view) {
            recon[ch].resize(rows_here, n);
            for (int v = 0; v < factored.view_count(); ++v) {
              for (int j = 0; j < k; ++j) {
                const float* src = factored.rows[j].data() + 3 * (v * texels + band_first + first) + ch;
                for (long long i = 0; i < rows_here; ++i) rows(i, j) = src[3 * i];
              }
              recon[ch].middleCols(static_cast<long long>(v) * set_columns, set_columns).noalias() =
                  rows * columns[v][ch].transpose();
            }
          } else {
            recon[ch] = rows * columns[0][ch].transpose();
          }
          band.FillRows(first, rows_here, Eigen::Vector3d::Unit(ch), &value[ch]);
        }
        double e = 0.0, t = 0.0;
        for (int ch = 0; ch < 3; ++ch) {
          const MatrixXd rgb = to_rgb(ch, 0) * recon[0] + to_rgb(ch, 1) * recon[1] + to_rgb(ch, 2) * recon[2];
          e += (rgb - value[ch]).squaredNorm();
          t += value[ch].squaredNorm();
        }
        error[offset + b] = e;
        norm[offset + b] = t;
      }
    });
  });
  double e = 0.0, t = 0.0;
  for (std::size_t b = 0; b < error.size(); ++b) {
    e += error[b];
    t += norm[b];
  }
  if (t == 0.0) return e == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
  return std::sqrt(e / t);
}

double RelativeRmsError(const core::FullBtf& truth, const core::FactoredBtf& factored) {
  core::InMemoryFullBtfReader reader(truth);
  return RelativeRmsError(reader, factored, BtfCompressionOptions{}.band_bytes);
}

}  // namespace mesocap::btf
