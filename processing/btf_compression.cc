#include "processing/btf_compression.h"

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

namespace mesocap {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// One channel of the BTF as the matrix A of a layout. Column j is a view
// image (paper) or one light's slice of one (per_texel); row p is the pixel
// index inside that column's W x H*Nlight (paper) or W x H (per_texel)
// region, so both layouts read contiguous runs of a view image.
class BtfMatrix {
 public:
  BtfMatrix(const FullBtf& btf, BtfFactorLayout layout, const Eigen::Vector3d& channel_weights)
      : btf_(btf), layout_(layout), weights_(channel_weights) {
    const long long texels = static_cast<long long>(btf.width) * btf.height;
    rows_ = layout == BtfFactorLayout::kPaper ? texels * btf.light_count() : texels;
    columns_ = layout == BtfFactorLayout::kPaper ? btf.view_count()
                                                 : static_cast<long long>(btf.view_count()) * btf.light_count();
  }

  long long rows() const { return rows_; }
  long long columns() const { return columns_; }

  // out = A(r0 .. r0+count-1, all columns).
  void FillRows(long long r0, long long count, MatrixXd* out) const {
    out->resize(count, columns_);
    for (long long j = 0; j < columns_; ++j) {
      const float* base = ColumnStart(j) + 3 * r0;
      for (long long i = 0; i < count; ++i) (*out)(i, j) = Value(base + 3 * i);
    }
  }
  // out = A(all rows, c0 .. c0+count-1)^T: row blocks of A^T.
  void FillTransposedRows(long long c0, long long count, MatrixXd* out) const {
    out->resize(count, rows_);
    for (long long j = 0; j < count; ++j) {
      const float* base = ColumnStart(c0 + j);
      for (long long i = 0; i < rows_; ++i) (*out)(j, i) = Value(base + 3 * i);
    }
  }

 private:
  const float* ColumnStart(long long j) const {
    if (layout_ == BtfFactorLayout::kPaper) return btf_.view_images[j].data();
    const int view = static_cast<int>(j / btf_.light_count());
    const long long light = j % btf_.light_count();
    return btf_.view_images[view].data() + 3 * light * btf_.height * btf_.width;
  }
  double Value(const float* rgb) const {
    return weights_[0] * rgb[0] + weights_[1] * rgb[1] + weights_[2] * rgb[2];
  }

  const FullBtf& btf_;
  BtfFactorLayout layout_;
  Eigen::Vector3d weights_;
  long long rows_ = 0;
  long long columns_ = 0;
};

using FillBlock = std::function<void(long long first, long long count, MatrixXd* out)>;

// Row-block sizes for streaming a rows x n matrix: about 2 MiB of doubles
// per block, never fewer rows than columns; a fixed number of blocks per
// parallel chunk, so the result does not depend on the thread count.
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

// The R factor of a tall matrix given by row blocks (TSQR): each chunk of
// blocks is reduced to its own R in parallel, the chunks' R are then stacked
// and reduced in order.
MatrixXd TallSkinnyR(long long rows, long long n, const FillBlock& fill) {
  const long long block = BlockRows(n);
  const long long chunk = block * kBlocksPerChunk;
  const long long chunks = (rows + chunk - 1) / chunk;
  std::vector<MatrixXd> chunk_r(chunks);
  tbb::parallel_for(tbb::blocked_range<long long>(0, chunks, 1), [&](const tbb::blocked_range<long long>& range) {
    MatrixXd a;
    for (long long c = range.begin(); c < range.end(); ++c) {
      MatrixXd r(0, n);
      const long long end = std::min(rows, (c + 1) * chunk);
      for (long long first = c * chunk; first < end; first += block) {
        fill(first, std::min(block, end - first), &a);
        r = StackedR(r, a);
      }
      chunk_r[c] = std::move(r);
    }
  });
  MatrixXd r(0, n);
  for (const MatrixXd& c : chunk_r) r = StackedR(r, c);
  return r;
}

struct ChannelSvd {
  VectorXd sigma;  // min(rows, n), descending
  MatrixXd right;  // n x min(rows, n): right singular vectors of the streamed matrix
};

// Singular values and right singular vectors of a matrix given by row blocks.
ChannelSvd TallSkinnySvd(long long rows, long long n, const FillBlock& fill) {
  const MatrixXd r = TallSkinnyR(rows, n, fill);
  Eigen::BDCSVD<MatrixXd> svd(r, Eigen::ComputeThinV);
  ChannelSvd out;
  out.sigma = svd.singularValues();
  out.right = svd.matrixV();
  return out;
}

// Runs body(first, count) over [0, total) in blocks of `block`, in parallel.
void ForBlocks(long long total, long long block, const std::function<void(long long, long long)>& body) {
  const long long blocks = (total + block - 1) / block;
  tbb::parallel_for(tbb::blocked_range<long long>(0, blocks, 1), [&](const tbb::blocked_range<long long>& range) {
    for (long long b = range.begin(); b < range.end(); ++b) {
      const long long first = b * block;
      body(first, std::min(block, total - first));
    }
  });
}

void CheckFinite(const FullBtf& btf) {
  if (btf.width < 1 || btf.height < 1) throw Error("compress: the BTF has no texels");
  if (static_cast<int>(btf.view_images.size()) != btf.view_count() || btf.view_count() < 1 ||
      btf.light_count() < 1) {
    throw Error("compress: the BTF has " + std::to_string(btf.view_images.size()) + " view images for " +
                std::to_string(btf.view_count()) + " views and " + std::to_string(btf.light_count()) +
                " lights");
  }
  for (int v = 0; v < btf.view_count(); ++v) {
    const Image& image = btf.view_images[v];
    if (image.width() != btf.width || image.height() != btf.height * btf.light_count() || image.channels() != 3) {
      throw Error("compress: BTF view " + std::to_string(v) + " image has the wrong size");
    }
    const float* data = image.data();
    for (std::size_t i = 0; i < image.size(); ++i) {
      if (!std::isfinite(data[i])) {
        const std::size_t pixel = i / 3;
        const int x = static_cast<int>(pixel % btf.width);
        const int row = static_cast<int>(pixel / btf.width);
        throw Error("compress: BTF view " + std::to_string(v) + " has a non-finite value at texel (" +
                    std::to_string(x) + ", " + std::to_string(row % btf.height) + "), light " +
                    std::to_string(row / btf.height) + ", channel " + std::to_string(i % 3));
      }
    }
  }
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

}  // namespace

CheckResult BtfCompressionOptions::Check() const {
  if (rank < 0 || rank > kMaxBtfRank) {
    return "rank " + std::to_string(rank) + " is outside 0..100 (0 chooses the rank by the error budget)";
  }
  if (rank == 0 && !(std::isfinite(max_relative_error) && max_relative_error > 0.0 && max_relative_error <= 1.0)) {
    return "max_relative_error " + std::to_string(max_relative_error) + " is outside (0, 1]";
  }
  return {};
}

FactoredBtf CompressBtf(const FullBtf& btf, const BtfCompressionOptions& options, BtfCompressionReport* report) {
  const auto start = std::chrono::steady_clock::now();
  if (const auto problem = options.Check(); !problem.empty()) throw Error("compress: " + problem);
  CheckFinite(btf);

  FactoredBtf out;
  out.width = btf.width;
  out.height = btf.height;
  out.views = btf.views;
  out.lights = btf.lights;
  out.layout = options.layout;
  out.color = options.color;
  out.rgb_to_factored =
      options.color == BtfFactorColor::kYCbCr ? YCbCrFromLinearRgbBt601() : Eigen::Matrix3d::Identity();

  const BtfMatrix shape(btf, options.layout, Eigen::Vector3d::UnitX());
  const long long m = shape.rows();
  const long long n = shape.columns();
  const bool tall = m >= n;
  const long long small = std::min(m, n);

  // Per channel: the SVD of A (tall) or of A^T (wide); `right` then holds
  // the right singular vectors of A (tall) or its left ones (wide).
  std::array<ChannelSvd, 3> svd;
  for (int ch = 0; ch < 3; ++ch) {
    const BtfMatrix a(btf, options.layout, out.rgb_to_factored.row(ch).transpose());
    if (tall) {
      svd[ch] = TallSkinnySvd(m, n, [&](long long f, long long c, MatrixXd* o) { a.FillRows(f, c, o); });
    } else {
      svd[ch] = TallSkinnySvd(n, m, [&](long long f, long long c, MatrixXd* o) { a.FillTransposedRows(f, c, o); });
    }
  }

  BtfCompressionReport local;
  BtfCompressionReport& r = report ? *report : local;
  r = BtfCompressionReport{};
  for (int ch = 0; ch < 3; ++ch) r.singular_values[ch] = svd[ch].sigma;
  r.max_rank = static_cast<int>(std::min<long long>(kMaxBtfRank, small));
  r.matrix_rows = m;
  r.matrix_columns = n;
  r.relative_rms_error = SpectrumErrors(r.singular_values, r.max_rank);

  const std::string space = options.color == BtfFactorColor::kRgb ? "" : " (in Y, Cb, Cr)";
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

  // Builds the factors of rank k from the channel SVDs.
  const auto build = [&](int k) {
    out.rows.assign(k, Image(btf.width, out.row_image_height(), 3));
    out.columns = Image(static_cast<int>(n), k, 3);
    for (int ch = 0; ch < 3; ++ch) {
      const BtfMatrix a(btf, options.layout, out.rgb_to_factored.row(ch).transpose());
      const ChannelSvd& s = svd[ch];
      const int usable = static_cast<int>(std::min<long long>(k, s.sigma.size()));
      // Numerically zero components (exactly rank-deficient data, a zero
      // channel): their share of A is rounding noise.
      const double tiny = static_cast<double>(small) * std::numeric_limits<double>::epsilon() *
                          (s.sigma.size() > 0 ? s.sigma[0] : 0.0);
      if (tall) {
        const MatrixXd v = s.right.leftCols(usable);
        for (int j = 0; j < usable; ++j) {
          for (long long c = 0; c < n; ++c) out.columns.pixel(static_cast<int>(c), j)[ch] = static_cast<float>(v(c, j));
        }
        // r_k = A v_k, from the data (see the header).
        ForBlocks(m, BlockRows(n), [&](long long first, long long count) {
          MatrixXd block;
          a.FillRows(first, count, &block);
          const MatrixXd rv = block * v;
          for (int j = 0; j < usable; ++j) {
            float* dst = out.rows[j].data() + 3 * first + ch;
            for (long long i = 0; i < count; ++i) dst[3 * i] = static_cast<float>(rv(i, j));
          }
        });
      } else {
        const MatrixXd u = s.right.leftCols(usable);
        for (int j = 0; j < usable; ++j) {
          if (!(s.sigma[j] > tiny)) continue;  // zero factors
          float* dst = out.rows[j].data() + ch;
          for (long long i = 0; i < m; ++i) dst[3 * i] = static_cast<float>(s.sigma[j] * u(i, j));
        }
        // c_k = A^T u_k / sigma_k.
        ForBlocks(n, BlockRows(m), [&](long long first, long long count) {
          MatrixXd block;
          a.FillTransposedRows(first, count, &block);
          const MatrixXd au = block * u;
          for (int j = 0; j < usable; ++j) {
            if (!(s.sigma[j] > tiny)) continue;
            for (long long i = 0; i < count; ++i) {
              out.columns.pixel(static_cast<int>(first + i), j)[ch] = static_cast<float>(au(i, j) / s.sigma[j]);
            }
          }
        });
      }
    }
  };

  build(rank);
  r.measured_relative_rms_error = RelativeRmsError(btf, out);
  // The budget is on RGB values; for ycbcr the spectrum measures the error in
  // the factored space, so the rank grows until the measured RGB error fits.
  if (options.rank == 0 && options.color == BtfFactorColor::kYCbCr) {
    while (r.measured_relative_rms_error > options.max_relative_error && rank < r.max_rank) {
      build(++rank);
      r.measured_relative_rms_error = RelativeRmsError(btf, out);
      r.reason = "rank " + std::to_string(rank) + ": smallest rank whose measured RGB error " +
                 Percent(r.measured_relative_rms_error) + " meets the budget " +
                 Percent(options.max_relative_error);
    }
  }
  r.rank = rank;
  out.CheckShape();
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  spdlog::debug("compress: {} x {} matrix per channel, rank {} ({}), {:.3g} s", m, n, rank, r.reason, r.seconds);
  return out;
}

nlohmann::json ToJson(const BtfCompressionReport& report, const FactoredBtf& factored) {
  const char* names[2][3] = {{"r", "g", "b"}, {"y", "cb", "cr"}};
  nlohmann::json spectrum = nlohmann::json::object();
  for (int ch = 0; ch < 3; ++ch) {
    const Eigen::VectorXd& s = report.singular_values[ch];
    spectrum[names[factored.color == BtfFactorColor::kYCbCr][ch]] = std::vector<double>(s.data(), s.data() + s.size());
  }
  return {{"layout", ToString(factored.layout)},
          {"color", ToString(factored.color)},
          {"rank", report.rank},
          {"reason", report.reason},
          {"measured_relative_rms", report.measured_relative_rms_error},
          {"relative_rms_by_rank", report.relative_rms_error},
          {"max_rank", report.max_rank},
          {"matrix_size", {report.matrix_rows, report.matrix_columns}},
          {"singular_values", spectrum},
          {"seconds", report.seconds}};
}

Image ReconstructBtfView(const FactoredBtf& f, int view) {
  f.CheckShape();
  if (view < 0 || view >= f.view_count()) throw Error("factored BTF: view " + std::to_string(view) + " out of range");
  Eigen::Matrix3d to_rgb = Eigen::Matrix3d::Identity();
  if (f.color == BtfFactorColor::kYCbCr) to_rgb = f.rgb_to_factored.inverse();
  const int nl = f.light_count();
  const long long texels = static_cast<long long>(f.width) * f.height;
  Image out(f.width, f.height * nl, 3);
  std::vector<double> acc(3 * texels);
  for (int l = 0; l < nl; ++l) {
    std::fill(acc.begin(), acc.end(), 0.0);
    // paper: rows (x, y, light), column view; per_texel: rows (x, y), column
    // view * Nlight + light.
    const bool paper = f.layout == BtfFactorLayout::kPaper;
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

double RelativeRmsError(const FullBtf& truth, const FactoredBtf& factored) {
  factored.CheckShape();
  if (truth.width != factored.width || truth.height != factored.height ||
      truth.view_count() != factored.view_count() || truth.light_count() != factored.light_count() ||
      static_cast<int>(truth.view_images.size()) != truth.view_count()) {
    throw Error("relative error: the BTF and its factors differ in size");
  }
  Eigen::Matrix3d to_rgb = Eigen::Matrix3d::Identity();
  if (factored.color == BtfFactorColor::kYCbCr) to_rgb = factored.rgb_to_factored.inverse();
  const BtfMatrix shape(truth, factored.layout, Eigen::Vector3d::UnitX());
  const long long m = shape.rows();
  const long long n = shape.columns();
  const int k = factored.rank();
  // Column factors per channel, n x K.
  std::array<MatrixXd, 3> columns;
  for (int ch = 0; ch < 3; ++ch) {
    columns[ch].resize(n, k);
    for (int j = 0; j < k; ++j) {
      for (long long c = 0; c < n; ++c) columns[ch](c, j) = factored.columns.pixel(static_cast<int>(c), j)[ch];
    }
  }
  const long long block = BlockRows(n);
  const long long blocks = (m + block - 1) / block;
  std::vector<double> error(blocks, 0.0), norm(blocks, 0.0);
  ForBlocks(m, block, [&](long long first, long long count) {
    std::array<MatrixXd, 3> recon, value;
    for (int ch = 0; ch < 3; ++ch) {
      MatrixXd rows(count, k);
      for (int j = 0; j < k; ++j) {
        const float* src = factored.rows[j].data() + 3 * first + ch;
        for (long long i = 0; i < count; ++i) rows(i, j) = src[3 * i];
      }
      recon[ch] = rows * columns[ch].transpose();
      BtfMatrix(truth, factored.layout, Eigen::Vector3d::Unit(ch)).FillRows(first, count, &value[ch]);
    }
    double e = 0.0, t = 0.0;
    for (int ch = 0; ch < 3; ++ch) {
      const MatrixXd rgb = to_rgb(ch, 0) * recon[0] + to_rgb(ch, 1) * recon[1] + to_rgb(ch, 2) * recon[2];
      e += (rgb - value[ch]).squaredNorm();
      t += value[ch].squaredNorm();
    }
    error[first / block] = e;
    norm[first / block] = t;
  });
  double e = 0.0, t = 0.0;
  for (long long b = 0; b < blocks; ++b) {
    e += error[b];
    t += norm[b];
  }
  if (t == 0.0) return e == 0.0 ? 0.0 : std::numeric_limits<double>::infinity();
  return std::sqrt(e / t);
}

}  // namespace mesocap
