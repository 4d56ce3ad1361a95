#include "btf/btf_svd.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <random>

namespace mesocap::btf::compression {
namespace {

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

// An orthonormal basis of the columns of y (thin Householder Q; columns past
// y's rank are completed to an orthonormal set, so rank-deficient sketches
// are fine).
MatrixXd OrthonormalBasis(const MatrixXd& y) {
  Eigen::HouseholderQR<MatrixXd> qr(y);
  return qr.householderQ() * MatrixXd::Identity(y.rows(), y.cols());
}

}  // namespace

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

}  // namespace mesocap::btf::compression
