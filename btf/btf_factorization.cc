#include "btf/btf_factorization.h"

#include <tbb/parallel_for.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <opencv2/core.hpp>
#include <random>

#include "btf/btf_svd.h"
#include "btf/streamed_btf_matrix.h"

namespace mesocap::btf::compression {
namespace {

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

}  // namespace

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

}  // namespace mesocap::btf::compression
