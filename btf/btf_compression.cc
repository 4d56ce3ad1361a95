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
#include <sstream>

namespace mesocap::btf {
namespace {

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

// One pass computing S(rows, :) * right[ch] for every row block of the
// streamed matrix S and channel; sink(ch, first_row, product) runs in
// parallel, each call for its own rows.
void ForEachProduct(const StreamedMatrix& s, const ChannelWeights& weights, const std::array<MatrixXd, 3>& right,
                    const std::function<void(int, long long, const MatrixXd&)>& sink) {
  const long long block = BlockRows(s.columns());
  s.ForEachBand([&](const MatrixBlock& band, long long band_first, long long count) {
    const long long blocks = (count + block - 1) / block;
    tbb::parallel_for(tbb::blocked_range<long long>(0, 3 * blocks, 1), [&](const tbb::blocked_range<long long>& range) {
      MatrixXd a;
      for (long long t = range.begin(); t < range.end(); ++t) {
        const int ch = static_cast<int>(t / blocks);
        const long long first = (t % blocks) * block;
        s.Fill(band, first, std::min(block, count - first), weights[ch], &a);
        sink(ch, band_first + first, a * right[ch]);
      }
    });
  });
}

// Relative error at every rank 1..max_rank from the spectra: the tail sums of
// sigma^2 are summed from the small end, so tiny errors are not lost to
// cancellation against ||A||^2.
std::vector<double> SpectrumErrors(const std::array<VectorXd, 3>& sigma, int max_rank) {
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

// The rank of the factorization: as requested (at most the matrix's), or the
// smallest whose spectrum error meets the budget; says why in report->reason.
int ChooseRank(const BtfCompressionOptions& options, core::BtfFactorColor color, long long m, long long n,
               BtfCompressionReport* report) {
  BtfCompressionReport& r = *report;
  const std::string space = color == core::BtfFactorColor::kRgb ? "" : " (in Y, Cb, Cr)";
  int rank = 0;
  if (options.rank > 0) {
    rank = std::min(options.rank, r.max_rank);
    r.reason = rank == options.rank
                   ? "rank " + std::to_string(rank) + " as requested"
                   : "rank " + std::to_string(options.rank) + " requested, but the " + std::to_string(m) + " x " +
                         std::to_string(n) + " matrix has at most rank " + std::to_string(rank);
  } else {
    rank = r.max_rank;
    for (int k = 1; k <= r.max_rank; ++k) {
      if (r.relative_rms_error[k - 1] <= options.max_relative_error) {
        rank = k;
        break;
      }
    }
    r.reason = r.relative_rms_error[rank - 1] <= options.max_relative_error
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

// The factors of one representation, the rank as options.rank or chosen by
// options.max_relative_error (max_bytes is turned into a rank by the caller).
core::FactoredBtf CompressOneRepresentation(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                                            core::BtfFactorLayout layout, core::BtfFactorColor color,
                                            BtfCompressionReport& r) {
  core::FactoredBtf out;
  out.width = btf.width();
  out.height = btf.height();
  out.views = btf.views();
  out.lights = btf.lights();
  out.layout = layout;
  out.color = color;
  out.rgb_to_factored =
      color == core::BtfFactorColor::kYCbCr ? core::YCbCrFromLinearRgbBt601() : Eigen::Matrix3d::Identity();
  ChannelWeights weights;
  for (int ch = 0; ch < 3; ++ch) weights[ch] = out.rgb_to_factored.row(ch).transpose();

  const BtfMatrix a(btf, layout);
  const long long m = a.rows();
  const long long n = a.columns();
  const bool tall = m >= n;
  const long long small = std::min(m, n);
  // The SVD of A (tall) or of A^T (wide); `right` then holds the right
  // singular vectors of A (tall) or its left ones (wide).
  const StreamedMatrix s(a, !tall, options.band_bytes);
  const std::array<ChannelSvd, 3> svd = TallSkinnySvd(s, weights);

  r = BtfCompressionReport{};
  for (int ch = 0; ch < 3; ++ch) r.singular_values[ch] = svd[ch].sigma;
  r.max_rank = static_cast<int>(std::min<long long>(core::kMaxBtfRank, small));
  r.matrix_rows = m;
  r.matrix_columns = n;
  r.relative_rms_error = SpectrumErrors(r.singular_values, r.max_rank);

  int rank = ChooseRank(options, color, m, n, &r);
  const FactorsFromSvd factors{s, weights, svd, tall, m, n, small};
  factors.Build(rank, &out);
  r.measured_relative_rms_error = RelativeRmsError(btf, out, options.band_bytes);
  // The budget is on RGB values; for ycbcr the spectrum measures the error in
  // the factored space, so the rank grows until the measured RGB error fits.
  if (options.rank == 0 && color == core::BtfFactorColor::kYCbCr) {
    while (r.measured_relative_rms_error > options.max_relative_error && rank < r.max_rank) {
      factors.Build(++rank, &out);
      r.measured_relative_rms_error = RelativeRmsError(btf, out, options.band_bytes);
      r.reason = "rank " + std::to_string(rank) + ": smallest rank whose measured RGB error " +
                 Percent(r.measured_relative_rms_error) + " meets the budget " + Percent(options.max_relative_error);
    }
  }
  r.rank = rank;
  r.factor_bytes = FactorBytes(layout, out.width, out.height, out.view_count(), out.light_count(), rank);
  out.CheckShape();
  spdlog::debug("compress: {} {}, {} x {} matrix per channel, rank {} ({})", ToString(layout), ToString(color), m, n,
                rank, r.reason);
  return out;
}

std::string RepresentationName(core::BtfFactorLayout layout, core::BtfFactorColor color) {
  return std::string(ToString(layout)) + "/" + ToString(color);
}

std::string Bytes(long long bytes) {
  std::ostringstream s;
  s.precision(3);
  s << bytes / 1024.0 << " KiB";
  return s.str();
}

// Whether candidate c is a better pick than the best so far: with a byte
// budget the more accurate; with an error budget the smaller of those that
// meet it, else (none meets it) the more accurate.
bool Better(const BtfRepresentationCandidate& c, const BtfRepresentationCandidate& best, bool byte_budget) {
  if (byte_budget || (!c.meets_budget && !best.meets_budget)) {
    return c.measured_relative_rms_error < best.measured_relative_rms_error ||
           (c.measured_relative_rms_error == best.measured_relative_rms_error && c.factor_bytes < best.factor_bytes);
  }
  if (c.meets_budget != best.meets_budget) return c.meets_budget;
  return c.factor_bytes < best.factor_bytes ||
         (c.factor_bytes == best.factor_bytes && c.measured_relative_rms_error < best.measured_relative_rms_error);
}

}  // namespace

long long FactorBytes(core::BtfFactorLayout layout, int width, int height, int views, int lights, int rank) {
  const bool paper = layout == core::BtfFactorLayout::kPaper;
  const long long row_pixels = static_cast<long long>(width) * height * (paper ? lights : 1);
  const long long columns = paper ? views : static_cast<long long>(views) * lights;
  return 3LL * static_cast<long long>(sizeof(float)) * rank * (row_pixels + columns);
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
  if (rank == 0 && max_bytes == 0 &&
      !(std::isfinite(max_relative_error) && max_relative_error > 0.0 && max_relative_error <= 1.0)) {
    return "max_relative_error " + std::to_string(max_relative_error) + " is outside (0, 1]";
  }
  return {};
}

core::FactoredBtf CompressBtf(core::FullBtfReader& btf, const BtfCompressionOptions& options,
                              BtfCompressionReport* report) {
  const auto start = std::chrono::steady_clock::now();
  if (const auto problem = options.Check(); !problem.empty()) throw core::Error("compress: " + problem);
  BtfCompressionReport local;
  BtfCompressionReport& r = report ? *report : local;

  std::vector<core::BtfFactorLayout> layouts{core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel};
  std::vector<core::BtfFactorColor> colors{core::BtfFactorColor::kRgb, core::BtfFactorColor::kYCbCr};
  if (options.layout) layouts = {*options.layout};
  if (options.color) colors = {*options.color};
  const bool choosing = layouts.size() * colors.size() > 1;
  const bool byte_budget = options.max_bytes > 0;

  core::FactoredBtf best;
  BtfCompressionReport best_report;
  std::vector<BtfRepresentationCandidate> candidates;
  int best_index = -1;
  for (const core::BtfFactorLayout layout : layouts) {
    for (const core::BtfFactorColor color : colors) {
      BtfRepresentationCandidate c{layout, color};
      BtfCompressionOptions one = options;
      if (byte_budget) {
        const long long per_rank =
            FactorBytes(layout, btf.width(), btf.height(), btf.view_count(), btf.light_count(), 1);
        one.rank = static_cast<int>(std::min<long long>(core::kMaxBtfRank, options.max_bytes / per_rank));
        if (one.rank == 0) {
          if (!choosing) {
            throw core::Error("compress: max_bytes " + std::to_string(options.max_bytes) + " is less than rank 1 of " +
                              RepresentationName(layout, color) + " (" + std::to_string(per_rank) + " bytes)");
          }
          c.factor_bytes = per_rank;
          candidates.push_back(c);
          continue;
        }
      }
      BtfCompressionReport one_report;
      core::FactoredBtf factored = CompressOneRepresentation(btf, one, layout, color, one_report);
      c.rank = one_report.rank;
      c.factor_bytes = one_report.factor_bytes;
      c.measured_relative_rms_error = one_report.measured_relative_rms_error;
      c.meets_budget = byte_budget ? c.factor_bytes <= options.max_bytes
                                   : options.rank > 0 || c.measured_relative_rms_error <= options.max_relative_error;
      candidates.push_back(c);
      if (best_index < 0 || Better(c, candidates[best_index], byte_budget)) {
        best_index = static_cast<int>(candidates.size()) - 1;
        best = std::move(factored);
        best_report = std::move(one_report);
      }
    }
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
  r = std::move(best_report);
  if (choosing) {
    const BtfRepresentationCandidate& c = candidates[best_index];
    const std::string name = RepresentationName(c.layout, c.color);
    const std::string figures =
        "rank " + std::to_string(c.rank) + ", " + Bytes(c.factor_bytes) + ", " + Percent(c.measured_relative_rms_error);
    if (byte_budget) {
      r.representation_reason = name + ": the most accurate of " + std::to_string(candidates.size()) +
                                " representations within " + Bytes(options.max_bytes) + " (" + figures + ")";
    } else if (c.meets_budget) {
      r.representation_reason = name + ": the smallest of the representations that meet the budget " +
                                Percent(options.max_relative_error) + " (" + figures + ")";
    } else {
      r.representation_reason = name + ": no representation meets the budget " + Percent(options.max_relative_error) +
                                " up to rank " + std::to_string(core::kMaxBtfRank) + "; the most accurate (" + figures +
                                ")";
    }
    r.candidates = std::move(candidates);
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return best;
}

core::FactoredBtf CompressBtf(const core::FullBtf& btf, const BtfCompressionOptions& options,
                              BtfCompressionReport* report) {
  core::InMemoryFullBtfReader reader(btf);
  return CompressBtf(reader, options, report);
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
    candidates.push_back({{"layout", ToString(c.layout)},
                          {"color", ToString(c.color)},
                          {"rank", c.rank},
                          {"factor_bytes", c.factor_bytes},
                          {"measured_relative_rms", c.measured_relative_rms_error},
                          {"meets_budget", c.meets_budget}});
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
                        {"singular_values", spectrum},
                        {"seconds", report.seconds}};
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
    // paper: rows (x, y, light), column view; per_texel: rows (x, y), column
    // view * Nlight + light.
    const bool paper = f.layout == core::BtfFactorLayout::kPaper;
    const int column = paper ? view : view * nl + l;
    const long long offset = paper ? 3 * l * texels : 0;
    for (int k = 0; k < f.rank(); ++k) {
      const float* c = f.columns.pixel(column, k);
      const float* r = f.rows[k].data() + offset;
      for (long long i = 0; i < texels; ++i)
        for (int ch = 0; ch < 3; ++ch) acc[3 * i + ch] += static_cast<double>(r[3 * i + ch]) * c[ch];
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
  // Column factors per channel, n x K.
  std::array<MatrixXd, 3> columns;
  for (int ch = 0; ch < 3; ++ch) {
    columns[ch].resize(n, k);
    for (int j = 0; j < k; ++j) {
      for (long long c = 0; c < n; ++c) columns[ch](c, j) = factored.columns.pixel(static_cast<int>(c), j)[ch];
    }
  }
  // Per row block, summed in block order so the result does not depend on
  // the thread count.
  const long long block = BlockRows(n);
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
          recon[ch] = rows * columns[ch].transpose();
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
