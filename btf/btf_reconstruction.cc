#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>

#include "btf/btf_compression.h"
#include "btf/streamed_btf_matrix.h"

namespace mesocap::btf {

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
  using compression::BtfMatrix, compression::MatrixBlock, compression::ProductBlockRows, compression::StreamedMatrix;
  using Eigen::MatrixXd;
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
