// SVD compression (Wang et al. 2005 Sec. 5) against exact answers: a flat
// Lambertian ground truth, exactly rank-deficient data, a 1000x specular
// highlight, a constant-zero channel, and the two layouts against each other.
#include "btf/btf_compression.h"

#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <functional>
#include <initializer_list>
#include <limits>
#include <random>

#include "core/image_io.h"
#include "formats/material_manifest.h"
#include "formats/material_package_writer.h"
#include "formats/package_full_btf_reader.h"
#include "sim/ground_truth.h"
#include "sim/mesostructure_scene.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::btf {
namespace {

using Fill = std::function<Eigen::Vector3f(int x, int y, int view, int light)>;

core::FullBtf MakeBtf(int size, const core::SamplingSet& views, const core::SamplingSet& lights, const Fill& fill) {
  core::FullBtf btf = core::MakeFullBtf(size, size, views, lights);
  for (int v = 0; v < btf.view_count(); ++v)
    for (int l = 0; l < btf.light_count(); ++l)
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          const Eigen::Vector3f c = fill(x, y, v, l);
          float* p = btf.view_images[v].pixel(x, l * size + y);
          for (int ch = 0; ch < 3; ++ch) p[ch] = c[ch];
        }
  return btf;
}

// Largest of f(x, y, view, light) over every value of a BTF of `shape`'s size.
double MaxOverValues(const core::FactoredBtf& shape, const std::function<double(int, int, int, int)>& f) {
  double worst = 0.0;
  for (int v = 0; v < shape.view_count(); ++v)
    for (int l = 0; l < shape.light_count(); ++l)
      for (int y = 0; y < shape.height; ++y)
        for (int x = 0; x < shape.width; ++x) worst = std::max(worst, f(x, y, v, l));
  return worst;
}

// Largest |reconstruction - input| over every value.
double MaxAbsError(const core::FullBtf& btf, const core::FactoredBtf& f) {
  return MaxOverValues(f, [&](int x, int y, int v, int l) {
    return static_cast<double>((f.Reconstruct(x, y, v, l) - btf.at(x, y, v, l)).cwiseAbs().maxCoeff());
  });
}

BtfCompressionOptions Options(core::BtfFactorLayout layout, core::BtfFactorColor color, int rank,
                              double budget = 0.01) {
  BtfCompressionOptions o;
  o.layout = layout;
  o.color = color;
  o.rank = rank;
  o.max_relative_error = budget;
  return o;
}

// Integer-valued data of rank 3 per channel in both layouts, sum_k
// a_k(x, y) b_k(view) c_k(light): every entry is exact in float, so the
// matrix is exactly of rank 3, not rank 3 plus float rounding.
Eigen::Vector3f IntegerRank3(int x, int y, int v, int l) {
  const int t = x + 3 * y;
  Eigen::Vector3f c;
  for (int ch = 0; ch < 3; ++ch) {
    const int a0 = (t * (ch + 1)) % 5 + 1, a1 = (t * 3 + ch) % 7 - 3, a2 = (t + 2 * ch) % 3;
    const int b0 = v % 4 + 1, b1 = (v * 5 + ch) % 3 - 1, b2 = (v * 2) % 5 - 2;
    const int c0 = l % 2 + 1, c1 = (l + ch) % 3, c2 = 2 - l % 4;
    c[ch] = static_cast<float>(a0 * b0 * c0 + a1 * b1 * c1 + a2 * b2 * c2);
  }
  return c;
}

// IntegerRank3 on 16 x 16 texels, grid6x2 views and grid5x2 lights, plus
// Gaussian noise of `sigma` (seeded): a spectrum with a tail.
core::FullBtf NoisyRank3Btf(unsigned seed, float sigma) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, sigma);
  core::FullBtf btf =
      MakeBtf(16, core::SamplingSet::Named("grid6x2"), core::SamplingSet::Named("grid5x2"), IntegerRank3);
  for (core::Image& view : btf.view_images)
    for (long long i = 0; i < static_cast<long long>(view.width()) * view.height() * 3; ++i)
      view.data()[i] += noise(rng);
  return btf;
}

TEST(BtfCompression, OptionsAreChecked) {
  EXPECT_TRUE(BtfCompressionOptions{}.Check().empty());
  BtfCompressionOptions o;
  o.rank = 101;
  EXPECT_NE(o.Check().find("rank 101"), std::string::npos);
  o.rank = 0;
  o.max_relative_error = 0.0;
  EXPECT_NE(o.Check().find("max_relative_error"), std::string::npos);
  o.max_relative_error = std::nan("");
  EXPECT_FALSE(o.Check().empty());
  o = BtfCompressionOptions{};
  o.rank = 4;
  o.layout.reset();
  EXPECT_NE(o.Check().find("layout and colour"), std::string::npos) << "a fixed rank needs one representation";
  o = BtfCompressionOptions{};
  o.rank = 4;
  o.max_bytes = 1000;
  EXPECT_NE(o.Check().find("not both"), std::string::npos);
  o.rank = 0;
  o.max_bytes = -1;
  EXPECT_NE(o.Check().find("max_bytes -1"), std::string::npos);
}

// The four representations with the layout and colour left open, under an
// error budget: a BTF that is a texel's albedo times a reflectance of (view,
// light) that is not separable has rank 1 per texel and a full rank in the
// paper's layout, so per_texel is the one that meets the budget in the fewest
// bytes.
TEST(BtfCompression, ChoosesTheSmallestRepresentationThatMeetsTheErrorBudget) {
  const core::SamplingSet views = core::SamplingSet::Named("grid6x3");
  const core::SamplingSet lights = core::SamplingSet::Named("grid6x4");
  const core::FullBtf btf = MakeBtf(8, views, lights, [](int x, int y, int v, int l) {
    const float albedo = 0.2f + 0.05f * static_cast<float>((x * 7 + y * 3) % 11);
    const float reflectance = 1.0f + 0.5f * std::sin(0.7f * static_cast<float>(v * v + 3 * l * l + v * l));
    const float s = albedo * reflectance;
    return Eigen::Vector3f(0.9f * s, 0.6f * s, 0.3f * s);
  });
  BtfCompressionOptions o;
  o.layout.reset();
  o.color.reset();
  o.max_relative_error = 1e-4;
  BtfCompressionReport report;
  const core::FactoredBtf f = CompressBtf(btf, o, &report);
  ASSERT_EQ(report.candidates.size(), 12u)
      << "paper, per_texel, clustered at 8, 32, 128 clusters and per_view, rgb and ycbcr";
  long long smallest_meeting = std::numeric_limits<long long>::max();
  for (const BtfRepresentationCandidate& c : report.candidates) {
    // A ycbcr representation whose spectrum already needs more bytes than the
    // best is not built.
    if (c.note.rfind("not built", 0) == 0) {
      EXPECT_EQ(c.color, core::BtfFactorColor::kYCbCr);
      EXPECT_FALSE(c.meets_budget);
      EXPECT_GE(c.factor_bytes, report.factor_bytes);
      continue;
    }
    // Factors as large as the BTF itself compress nothing and do not count.
    const long long full_bytes = 64LL * btf.view_count() * btf.light_count() * 12;
    EXPECT_EQ(c.meets_budget, c.relative_rms_error <= 1e-4 && c.factor_bytes < full_bytes)
        << ToString(c.layout) << " " << ToString(c.color);
    if (c.relative_rms_error <= 1e-4 && !c.meets_budget) {
      EXPECT_NE(c.note.find("full BTF"), std::string::npos) << c.note;
    }
    EXPECT_EQ(c.factor_bytes, FactorBytes(c.layout, 8, 8, btf.view_count(), btf.light_count(), c.rank, c.clusters));
    if (c.meets_budget) smallest_meeting = std::min(smallest_meeting, c.factor_bytes);
  }
  EXPECT_EQ(f.layout, core::BtfFactorLayout::kPerTexel);
  EXPECT_EQ(f.rank(), 1);
  EXPECT_EQ(report.factor_bytes, smallest_meeting);
  EXPECT_EQ(report.factor_bytes, 12LL * (64 + btf.view_count() * btf.light_count()));
  EXPECT_NE(report.representation_reason.find("per_texel"), std::string::npos) << report.representation_reason;
  EXPECT_NEAR(RelativeRmsError(btf, f), report.measured_relative_rms_error, 1e-9);
  EXPECT_LE(report.measured_relative_rms_error, 1e-4);
  // The paper layout needs many more bytes for the same budget, or misses it.
  for (const BtfRepresentationCandidate& c : report.candidates) {
    if (c.layout == core::BtfFactorLayout::kPaper) {
      EXPECT_TRUE(!c.meets_budget || c.factor_bytes > 10 * smallest_meeting);
    }
  }
}

// Clustered local PCA (Mueller et al. 2003): two materials side by side, each
// a texel's albedo times its own reflectance of (view, light), are rank 2
// for one SVD of all texels but rank 1 in each of two clusters; the clusters
// are the materials.
TEST(BtfCompression, ClusteredLayoutFactorsTwoMaterialsAtRankOne) {
  const core::SamplingSet views = core::SamplingSet::Named("grid6x3");
  const core::SamplingSet lights = core::SamplingSet::Named("grid6x4");
  const auto material = [](int x) { return x % 3 == 0 ? 0 : 1; };
  const core::FullBtf btf = MakeBtf(8, views, lights, [&](int x, int y, int v, int l) {
    const float albedo = 0.3f + 0.04f * static_cast<float>((x + 5 * y) % 7);
    const float a = 1.0f + 0.5f * std::sin(0.7f * static_cast<float>(v * v + 3 * l));
    const float b =
        0.2f + std::cos(0.3f * static_cast<float>(l * l + 2 * v)) * std::cos(0.3f * static_cast<float>(l * l + 2 * v));
    const float s = albedo * (material(x) == 0 ? a : b);
    return Eigen::Vector3f(0.8f * s, 0.5f * s, 0.4f * s);
  });
  BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kClustered;
  o.color = core::BtfFactorColor::kRgb;
  o.clusters = 2;
  o.max_relative_error = 1e-5;
  BtfCompressionReport report;
  const core::FactoredBtf f = CompressBtf(btf, o, &report);
  EXPECT_EQ(f.rank(), 1);
  EXPECT_EQ(f.cluster_count, 2);
  EXPECT_LE(report.measured_relative_rms_error, 1e-5);
  EXPECT_NEAR(RelativeRmsError(btf, f), report.measured_relative_rms_error, 1e-9);
  EXPECT_LT(MaxAbsError(btf, f), 1e-5);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      EXPECT_EQ(f.texel_clusters[y * 8 + x] == f.texel_clusters[0], material(x) == material(0)) << x << "," << y;
    }
  EXPECT_EQ(report.factor_bytes, 12LL * (64 + 2 * btf.view_count() * btf.light_count()) + 4 * 64);
  // One SVD of all texels needs a second term.
  o.layout = core::BtfFactorLayout::kPerTexel;
  EXPECT_EQ(CompressBtf(btf, o).rank(), 2);
}

// The per-view factorisation (Sattler et al. 2003): a BTF whose every view
// is one texture times a reflectance of the light, T = a_v(x, y) b_v(l), with
// the texture moving from view to view (parallax), is rank 1 in each view's
// matrix but of high rank in the per_texel and paper layouts.
TEST(BtfCompression, PerViewLayoutFactorsEachViewAtRankOne) {
  const core::SamplingSet views = core::SamplingSet::Named("grid6x3");
  const core::SamplingSet lights = core::SamplingSet::Named("grid6x4");
  const core::FullBtf btf = MakeBtf(8, views, lights, [](int x, int y, int v, int l) {
    const float a = 0.2f + 0.05f * static_cast<float>((x + v + 3 * y) % 9);  // shifts with the view
    const float b = 1.0f + 0.5f * std::sin(0.7f * static_cast<float>(l * l + v));
    return Eigen::Vector3f(0.9f * a * b, 0.6f * a * b, 0.3f * a * b);
  });
  BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kPerView;
  o.color = core::BtfFactorColor::kRgb;
  o.max_relative_error = 1e-6;
  BtfCompressionReport report;
  const core::FactoredBtf f = CompressBtf(btf, o, &report);
  EXPECT_EQ(f.layout, core::BtfFactorLayout::kPerView);
  EXPECT_EQ(f.rank(), 1);
  EXPECT_LT(MaxAbsError(btf, f), 1e-5);
  EXPECT_NEAR(RelativeRmsError(btf, f), report.measured_relative_rms_error, 1e-9);
  const int nv = btf.view_count(), nl = btf.light_count();
  EXPECT_EQ(report.factor_bytes, 12LL * (64 * nv + nl * nv));
  EXPECT_EQ(report.factor_bytes, FactorBytes(core::BtfFactorLayout::kPerView, 8, 8, nv, nl, 1));
  // The view images reconstructed whole agree with the texel-wise path.
  for (int v : {0, nv / 2, nv - 1}) {
    const core::Image view = ReconstructBtfView(f, v);
    for (int l : {0, nl - 1})
      for (int y = 0; y < 8; y += 3)
        for (int x = 0; x < 8; x += 3) EXPECT_NEAR(view.at(x, l * 8 + y, 1), f.Reconstruct(x, y, v, l).y(), 1e-6);
  }
  // One SVD of all texels, or of all views, needs more terms.
  o.layout = core::BtfFactorLayout::kPerTexel;
  EXPECT_GT(CompressBtf(btf, o).rank(), 1);
  o.layout = core::BtfFactorLayout::kPaper;
  EXPECT_GT(CompressBtf(btf, o).rank(), 1);
}

// Clusters of one texel each, and clusters of identical texels: exact, no
// NaN, whatever k-means makes of duplicates.
TEST(BtfCompression, ClustersOfOneTexelOrOfIdenticalTexelsAreExact) {
  const core::SamplingSet views = core::SamplingSet::Named("grid6x2");
  const core::SamplingSet lights = core::SamplingSet::Named("grid5x2");
  const core::FullBtf varied = MakeBtf(4, views, lights, IntegerRank3);
  BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kClustered;
  o.color = core::BtfFactorColor::kRgb;
  o.clusters = 16;  // one texel each
  o.max_relative_error = 1e-6;
  BtfCompressionReport report;
  const core::FactoredBtf one_each = CompressBtf(varied, o, &report);
  EXPECT_EQ(one_each.cluster_count, 16);
  EXPECT_EQ(one_each.rank(), 1) << "a cluster of one texel is one row: rank 1";
  EXPECT_LT(MaxAbsError(varied, one_each), 1e-4);

  const core::FullBtf same = MakeBtf(4, views, lights, [](int, int, int v, int l) {
    return Eigen::Vector3f(0.1f * static_cast<float>(v + 1), 0.2f, 0.05f * static_cast<float>(l + 1));
  });
  o.clusters = 8;
  const core::FactoredBtf identical = CompressBtf(same, o, &report);
  EXPECT_GE(identical.cluster_count, 1);
  EXPECT_LE(identical.cluster_count, 8);
  EXPECT_EQ(identical.rank(), 1);
  EXPECT_LT(MaxAbsError(same, identical), 1e-6);
  EXPECT_TRUE(std::isfinite(report.measured_relative_rms_error));
}

// With a byte budget: every representation at the largest rank whose factors
// fit, and the most accurate of them kept; a budget below rank 1 of every
// representation is an error that names the smallest.
TEST(BtfCompression, ByteBudgetKeepsTheMostAccurateFactorsThatFit) {
  const core::FullBtf btf = NoisyRank3Btf(7, 0.05f);
  const int nv = btf.view_count(), nl = btf.light_count();
  const long long budget = FactorBytes(core::BtfFactorLayout::kPerTexel, 16, 16, nv, nl, 3) + 100;

  BtfCompressionOptions o;
  o.layout.reset();
  o.color.reset();
  o.max_bytes = budget;
  BtfCompressionReport report;
  const core::FactoredBtf f = CompressBtf(btf, o, &report);
  ASSERT_EQ(report.candidates.size(), 12u);
  EXPECT_LE(report.factor_bytes, budget);
  for (const BtfRepresentationCandidate& c : report.candidates) {
    if (c.rank == 0) continue;  // not even rank 1 fits
    EXPECT_LE(c.factor_bytes, budget);
    if (c.layout == core::BtfFactorLayout::kPaper ||
        c.layout == core::BtfFactorLayout::kPerTexel) {  // clusters may run out
                                                         // of texels first
      EXPECT_GT(FactorBytes(c.layout, 16, 16, nv, nl, c.rank + 1), budget) << "the largest rank that fits";
    }
    EXPECT_LE(report.measured_relative_rms_error, c.relative_rms_error + 1e-9);
  }
  EXPECT_NEAR(RelativeRmsError(btf, f), report.measured_relative_rms_error, 1e-9);
  EXPECT_NE(report.representation_reason.find("most accurate"), std::string::npos);

  // One representation given: the budget picks its rank.
  o.layout = core::BtfFactorLayout::kPaper;
  o.color = core::BtfFactorColor::kRgb;
  o.max_bytes = FactorBytes(core::BtfFactorLayout::kPaper, 16, 16, nv, nl, 2) + 5;
  const core::FactoredBtf paper = CompressBtf(btf, o, &report);
  EXPECT_EQ(paper.rank(), 2);
  EXPECT_TRUE(report.candidates.empty());

  o.layout.reset();
  o.color.reset();
  o.max_bytes = 10;
  try {
    CompressBtf(btf, o);
    ADD_FAILURE() << "10 bytes hold no factors";
  } catch (const core::Error& e) {
    const long long smallest = std::min(FactorBytes(core::BtfFactorLayout::kPaper, 16, 16, nv, nl, 1),
                                        FactorBytes(core::BtfFactorLayout::kPerTexel, 16, 16, nv, nl, 1));
    EXPECT_NE(std::string(e.what()).find("max_bytes 10"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(std::to_string(smallest)), std::string::npos) << e.what();
  }
}

// While choosing, an rgb representation's error is taken from its spectrum
// and its factors are not built; that error must be what its factors give.
// Each candidate is compressed again on its own at the rank chosen for it,
// and measured; the spectrum's error agrees to float rounding. A ycbcr
// representation is built and measured unless its spectrum's rank already
// takes more bytes than the best.
TEST(BtfCompression, SpectrumErrorsOfCandidatesAreWhatTheirFactorsGive) {
  const core::FullBtf btf = NoisyRank3Btf(11, 0.02f);
  BtfCompressionOptions o;
  o.layout.reset();
  o.color.reset();
  o.max_relative_error = 0.05;
  BtfCompressionReport report;
  const core::FactoredBtf chosen = CompressBtf(btf, o, &report);
  ASSERT_EQ(report.candidates.size(), 12u);
  int from_spectrum = 0;
  for (const BtfRepresentationCandidate& c : report.candidates) {
    SCOPED_TRACE(std::string(ToString(c.layout)) + "/" + ToString(c.color) + " " + std::to_string(c.clusters));
    ASSERT_GT(c.rank, 0) << c.note;
    if (c.note.rfind("not built", 0) == 0) {
      EXPECT_GE(c.factor_bytes, report.factor_bytes);
      continue;
    }
    from_spectrum += c.measured ? 0 : 1;
    EXPECT_TRUE(c.measured || c.color == core::BtfFactorColor::kRgb);
    BtfCompressionOptions alone;
    alone.layout = c.layout;
    alone.color = c.color;
    alone.clusters = c.layout == core::BtfFactorLayout::kClustered ? c.clusters : 0;
    alone.rank = c.rank;
    BtfCompressionReport measured;
    CompressBtf(btf, alone, &measured);
    EXPECT_NEAR(c.relative_rms_error, measured.measured_relative_rms_error,
                1e-6 * measured.measured_relative_rms_error);
  }
  EXPECT_GE(from_spectrum, 4) << "every rgb representation but the one kept";
  EXPECT_NEAR(RelativeRmsError(btf, chosen), report.measured_relative_rms_error, 1e-9);
  EXPECT_LE(report.measured_relative_rms_error, 0.05);
}

TEST(BtfCompression, FlatLambertianGroundTruthIsRankOne) {
  const auto scene = sim::MakeBuiltinScene("flat");
  sim::GroundTruthOptions gt;
  gt.texels.width = gt.texels.height = 8;
  gt.texels.sample_size_mm = 6.0;
  gt.views = core::SamplingSet::Named("grid6x3");
  gt.lights = core::SamplingSet::Named("grid6x4");
  const core::FullBtf btf = sim::RenderTrueBtf(*scene, gt);
  for (auto layout : {core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel}) {
    for (auto color : {core::BtfFactorColor::kRgb, core::BtfFactorColor::kYCbCr}) {
      BtfCompressionReport report;
      const core::FactoredBtf f = CompressBtf(btf, Options(layout, color, 0, 1e-4), &report);
      EXPECT_EQ(f.rank(), 1) << ToString(layout) << " " << ToString(color) << ": " << report.reason;
      EXPECT_EQ(report.rank, 1);
      EXPECT_LT(report.relative_rms_error[0], 1e-4);
      EXPECT_LT(report.measured_relative_rms_error, 1e-4);
      EXPECT_NEAR(f.Reconstruct(3, 5, 7, 11).x(), 0.5 / M_PI, 1e-5);
    }
  }
}

TEST(BtfCompression, ExactlyRankDeficientDataHasZeroTailAndRankThreeIsExact) {
  // 12 views, 16 x 16 texels, 10 lights: paper matrix 2560 x 12 of rank 3.
  const core::FullBtf btf =
      MakeBtf(16, core::SamplingSet::Named("grid6x2"), core::SamplingSet::Named("grid5x2"), IntegerRank3);
  for (auto layout : {core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel}) {
    BtfCompressionReport report;
    const core::FactoredBtf f = CompressBtf(btf, Options(layout, core::BtfFactorColor::kRgb, 0, 1e-6), &report);
    for (int ch = 0; ch < 3; ++ch) {
      const Eigen::VectorXd& s = report.singular_values[ch];
      ASSERT_GE(s.size(), 4);
      EXPECT_GT(s[2], 1e-3 * s[0]) << "channel " << ch;
      // Backward-stable SVD: the zero singular values come out at rounding
      // level (a Gram-matrix method would stop at ~1e-8 of sigma_max).
      EXPECT_LT(s[3], 1e-12 * s[0]) << "channel " << ch;
    }
    EXPECT_EQ(f.rank(), 3) << report.reason;
    EXPECT_LT(report.measured_relative_rms_error, 1e-6);
    EXPECT_LT(MaxAbsError(btf, f), 2e-5);  // values up to ~40, float factors
    // A requested rank above the numerical rank still reconstructs exactly
    // (the extra components are rounding noise, not garbage).
    const core::FactoredBtf f8 = CompressBtf(btf, Options(layout, core::BtfFactorColor::kRgb, 8));
    EXPECT_EQ(f8.rank(), 8);
    EXPECT_LT(MaxAbsError(btf, f8), 2e-5);
  }
}

TEST(BtfCompression, SpecularHighlightThousandTimesDiffuse) {
  // Diffuse 0.1 with a texture, plus a highlight 1000x brighter where the
  // view is the mirror of the light -- a few columns with huge values.
  const core::SamplingSet views = core::SamplingSet::Named("grid8x3");
  const core::SamplingSet lights = views;
  const core::FullBtf btf = MakeBtf(8, views, lights, [&](int x, int y, int v, int l) {
    const float albedo = 0.1f * (1.0f + 0.5f * std::sin(0.9f * x + 0.4f * y));
    const Eigen::Vector3d mirror(-lights.direction(l).x(), -lights.direction(l).y(), lights.direction(l).z());
    const bool highlight = (mirror - views.direction(v)).norm() < 1e-6 && (x + y) % 3 == 0;
    const float s = highlight ? 100.0f : 0.0f;  // 1000x the diffuse level
    return Eigen::Vector3f(albedo + s, 0.8f * albedo + s, 0.5f * albedo + s);
  });
  for (auto layout : {core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel}) {
    BtfCompressionReport report;
    const core::FactoredBtf full = CompressBtf(btf, Options(layout, core::BtfFactorColor::kRgb, 24), &report);
    ASSERT_EQ(report.rank, std::min(24, report.max_rank));
    // At the matrix's full rank (paper: 24 views) the factors reproduce the
    // diffuse level next to the highlight: float rounding of the ~100 values
    // is ~1e-5, far below the 0.1 diffuse level.
    if (layout == core::BtfFactorLayout::kPaper) {
      EXPECT_LT(MaxAbsError(btf, full), 1e-4);
      EXPECT_NEAR(full.Reconstruct(1, 1, 5, 5).y(), btf.at(1, 1, 5, 5).y(), 1e-4);
    }
    // The spectrum's error at each rank is the measured error of the
    // truncated factors (Eckart-Young), within float storage of the factors.
    for (int k : {1, 2, 4, 8}) {
      const core::FactoredBtf f = CompressBtf(btf, Options(layout, core::BtfFactorColor::kRgb, k));
      const double measured = RelativeRmsError(btf, f);
      EXPECT_NEAR(measured, report.relative_rms_error[k - 1], 1e-4 * report.relative_rms_error[k - 1] + 1e-6)
          << ToString(layout) << " rank " << k;
    }
    // The budget picks the smallest rank that meets it, and says so.
    BtfCompressionReport chosen;
    const core::FactoredBtf f = CompressBtf(btf, Options(layout, core::BtfFactorColor::kRgb, 0, 0.01), &chosen);
    EXPECT_LE(chosen.measured_relative_rms_error, 0.01);
    if (chosen.rank > 1) {
      EXPECT_GT(chosen.relative_rms_error[chosen.rank - 2], 0.01);
    }
    EXPECT_NE(chosen.reason.find("budget"), std::string::npos) << chosen.reason;
  }
}

TEST(BtfCompression, ConstantZeroChannelGivesZeroFactorsAndNoNaN) {
  const core::SamplingSet views = core::SamplingSet::Named("grid5x2");
  const core::SamplingSet lights = core::SamplingSet::Named("grid4x2");
  const core::FullBtf btf = MakeBtf(4, views, lights, [](int x, int y, int v, int l) {
    const float r = IntegerRank3(x, y, v, l).x();
    return Eigen::Vector3f(r, 0.5f * r, 0.0f);
  });
  // paper: 128 x 10 (tall); per_texel: 16 x 80 (wide, factored through A^T);
  // per_view: 10 views' 16 x 8.
  for (auto layout :
       {core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel, core::BtfFactorLayout::kPerView}) {
    for (auto color : {core::BtfFactorColor::kRgb, core::BtfFactorColor::kYCbCr}) {
      BtfCompressionReport report;
      const core::FactoredBtf f = CompressBtf(btf, Options(layout, color, 6), &report);
      for (const core::Image& r : f.rows)
        for (std::size_t i = 0; i < r.size(); ++i) ASSERT_TRUE(std::isfinite(r.data()[i]));
      for (std::size_t i = 0; i < f.columns.size(); ++i) ASSERT_TRUE(std::isfinite(f.columns.data()[i]));
      if (color == core::BtfFactorColor::kRgb) {
        EXPECT_EQ(report.singular_values[2].norm(), 0.0);
        for (const core::Image& r : f.rows)
          for (int i = 0; i < r.width() * r.height(); ++i) ASSERT_EQ(r.data()[3 * i + 2], 0.0f);
      }
      EXPECT_LT(MaxAbsError(btf, f), 2e-5) << ToString(layout) << " " << ToString(color);
      EXPECT_NEAR(f.Reconstruct(2, 3, 4, 5).z(), 0.0, 1e-5);
    }
  }
  // All zero: every error is 0 and rank 1 is chosen.
  const core::FullBtf zero = MakeBtf(4, views, lights, [](int, int, int, int) { return Eigen::Vector3f::Zero(); });
  BtfCompressionReport report;
  const core::FactoredBtf f =
      CompressBtf(zero, Options(core::BtfFactorLayout::kPaper, core::BtfFactorColor::kRgb, 0), &report);
  EXPECT_EQ(f.rank(), 1);
  EXPECT_EQ(report.measured_relative_rms_error, 0.0);
}

TEST(BtfCompression, LayoutsAgreeAtFullRank) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const core::SamplingSet views = core::SamplingSet::Named("grid3x2");
  const core::SamplingSet lights = core::SamplingSet::Named("grid5x1");
  core::FullBtf btf =
      MakeBtf(4, views, lights, [&](int, int, int, int) { return Eigen::Vector3f(u(rng), u(rng), u(rng)); });
  // paper: 80 x 6, full rank 6; per_texel: 16 x 30 (wide), full rank 16.
  const core::FactoredBtf paper =
      CompressBtf(btf, Options(core::BtfFactorLayout::kPaper, core::BtfFactorColor::kRgb, 6));
  const core::FactoredBtf texel =
      CompressBtf(btf, Options(core::BtfFactorLayout::kPerTexel, core::BtfFactorColor::kYCbCr, 16));
  // per_view: 6 views' 16 x 5, full rank 5.
  const core::FactoredBtf per_view =
      CompressBtf(btf, Options(core::BtfFactorLayout::kPerView, core::BtfFactorColor::kRgb, 5));
  for (int v = 0; v < 6; ++v)
    for (int l = 0; l < 5; ++l)
      for (int y = 0; y < 4; ++y)
        for (int x = 0; x < 4; ++x) {
          ASSERT_LT((paper.Reconstruct(x, y, v, l) - texel.Reconstruct(x, y, v, l)).cwiseAbs().maxCoeff(), 2e-6);
          ASSERT_LT((paper.Reconstruct(x, y, v, l) - per_view.Reconstruct(x, y, v, l)).cwiseAbs().maxCoeff(), 2e-6);
          ASSERT_LT((paper.Reconstruct(x, y, v, l) - btf.at(x, y, v, l)).cwiseAbs().maxCoeff(), 2e-6);
        }
}

TEST(BtfCompression, StreamedQrMatchesADirectSvdAcrossManyBlocks) {
  // 64 views x (32 x 32 texels x 36 lights): 36864 rows, more than one
  // parallel chunk of row blocks, so the chunk reduction is exercised.
  std::mt19937 rng(11);
  std::normal_distribution<float> g(0.0f, 1.0f);
  const core::SamplingSet views = core::SamplingSet::Named("grid16x4");
  const core::SamplingSet lights = core::SamplingSet::Named("grid9x4");
  const core::FullBtf btf = MakeBtf(32, views, lights, [&](int x, int, int v, int) {
    // A decaying spectrum: smooth part plus small noise.
    const float s = std::cos(0.1f * x * (v % 5 + 1));
    return Eigen::Vector3f(s + 0.01f * g(rng), 0.5f * s, 1e-3f * g(rng));
  });
  BtfCompressionReport report;
  CompressBtf(btf, Options(core::BtfFactorLayout::kPaper, core::BtfFactorColor::kRgb, 10), &report);
  for (int ch = 0; ch < 3; ++ch) {
    Eigen::MatrixXd a(32 * 32 * 36, 64);
    for (int v = 0; v < 64; ++v)
      for (int p = 0; p < a.rows(); ++p) a(p, v) = btf.view_images[v].data()[3 * p + ch];
    // One-sided Jacobi (after a QR) as the reference: another algorithm than
    // the divide and conquer inside CompressBtf, and a quarter of its compile
    // time.
    const Eigen::VectorXd direct = Eigen::JacobiSVD<Eigen::MatrixXd>(a).singularValues();
    const Eigen::VectorXd& streamed = report.singular_values[ch];
    ASSERT_EQ(streamed.size(), 64);
    for (int k = 0; k < 64; ++k) EXPECT_NEAR(streamed[k], direct[k], 1e-11 * direct[0]) << "ch " << ch << " k " << k;
  }
}

// The randomized SVD against the exact one on a decaying spectrum (smooth
// data plus noise), tall (per_texel 576 x 288) and wide (64 x 288, streamed
// as A^T): at every rank its measured error is within 1 % of the exact
// (optimal) one, and its leading singular values within 1e-3.
TEST(BtfCompression, RandomizedSvdMatchesTheExactOneOnADecayingSpectrum) {
  const core::SamplingSet views = core::SamplingSet::Named("grid8x3");
  const core::SamplingSet lights = core::SamplingSet::Named("grid6x2");
  for (const int size : {24, 8}) {
    std::mt19937 rng(3);
    std::normal_distribution<float> g(0.0f, 1.0f);
    const core::FullBtf btf = MakeBtf(size, views, lights, [&](int x, int y, int v, int l) {
      float s = 0.0f;
      for (int k = 1; k <= 6; ++k)
        s += std::pow(0.5f, k) * std::cos(0.37f * k * x + 0.21f * k * y + 0.5f * k * v - 0.3f * l);
      return Eigen::Vector3f(1.0f + s + 0.003f * g(rng), 0.5f + 0.7f * s, 0.2f + 0.002f * g(rng));
    });
    for (const int rank : {2, 4, 8}) {
      SCOPED_TRACE("texels " + std::to_string(size) + "^2, rank " + std::to_string(rank));
      BtfCompressionOptions exact = Options(core::BtfFactorLayout::kPerTexel, core::BtfFactorColor::kRgb, rank);
      exact.svd = BtfSvdMethod::kExact;
      BtfCompressionOptions randomized = exact;
      randomized.svd = BtfSvdMethod::kRandomized;
      BtfCompressionReport e, r;
      CompressBtf(btf, exact, &e);
      CompressBtf(btf, randomized, &r);
      EXPECT_EQ(e.svd, "exact");
      EXPECT_EQ(r.svd.rfind("randomized", 0), 0u) << r.svd;
      EXPECT_GE(r.measured_relative_rms_error, e.measured_relative_rms_error * (1.0 - 1e-6));
      EXPECT_LE(r.measured_relative_rms_error, e.measured_relative_rms_error * 1.01);
      EXPECT_NEAR(r.relative_rms_error[rank - 1], e.relative_rms_error[rank - 1],
                  0.01 * e.relative_rms_error[rank - 1]);
      for (int k = 0; k < rank; ++k) {
        EXPECT_NEAR(r.singular_values[0][k], e.singular_values[0][k], 1e-3 * e.singular_values[0][k]) << "k " << k;
      }
    }
  }
}

// Exactly rank-3 data: the sketch spans the whole range, so the randomized
// SVD is exact at rank 3 and above, and a zero channel gives zero factors.
TEST(BtfCompression, RandomizedSvdIsExactOnRankDeficientDataAndAZeroChannel) {
  const core::FullBtf btf = MakeBtf(16, core::SamplingSet::Named("grid6x2"), core::SamplingSet::Named("grid5x2"),
                                    [](int x, int y, int v, int l) {
                                      const Eigen::Vector3f c = IntegerRank3(x, y, v, l);
                                      return Eigen::Vector3f(c.x(), c.y(), 0.0f);
                                    });
  for (const int rank : {3, 8}) {
    BtfCompressionOptions o = Options(core::BtfFactorLayout::kPerTexel, core::BtfFactorColor::kRgb, rank);
    o.svd = BtfSvdMethod::kRandomized;
    BtfCompressionReport report;
    const core::FactoredBtf f = CompressBtf(btf, o, &report);
    EXPECT_LT(report.measured_relative_rms_error, 1e-6) << "rank " << rank;
    EXPECT_LT(MaxAbsError(btf, f), 2e-5) << "rank " << rank;
    EXPECT_LT(report.relative_rms_error[2], 1e-6);
    for (const core::Image& r : f.rows)
      for (int i = 0; i < r.width() * r.height(); ++i) ASSERT_EQ(r.data()[3 * i + 2], 0.0f);
  }
}

TEST(BtfCompression, RejectsNonFiniteValuesNamingTheView) {
  core::FullBtf btf = MakeBtf(4, core::SamplingSet::Named("grid3x1"), core::SamplingSet::Named("grid2x1"),
                              [](int, int, int, int) { return Eigen::Vector3f(1, 1, 1); });
  btf.view_images[2].pixel(1, 4 + 3)[1] = std::nanf("");
  for (auto layout : {core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel,
                      core::BtfFactorLayout::kClustered, core::BtfFactorLayout::kPerView}) {
    BtfCompressionOptions o;
    o.layout = layout;
    try {
      CompressBtf(btf, o);
      ADD_FAILURE() << ToString(layout) << ": expected an error";
    } catch (const core::Error& e) {
      EXPECT_NE(std::string(e.what()).find("view 2"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("texel (1, 3), light 1"), std::string::npos) << e.what();
    }
  }
}

// Largest |a - b| of the two factorizations' reconstructions over every value.
double MaxAbsDifference(const core::FactoredBtf& a, const core::FactoredBtf& b) {
  return MaxOverValues(a, [&](int x, int y, int v, int l) {
    return static_cast<double>((a.Reconstruct(x, y, v, l) - b.Reconstruct(x, y, v, l)).cwiseAbs().maxCoeff());
  });
}

core::FullBtf RandomSmoothBtf(int size, const core::SamplingSet& views, const core::SamplingSet& lights,
                              unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.0f, 1.0f);
  return MakeBtf(size, views, lights, [&](int x, int y, int v, int l) {
    const float s = std::cos(0.3f * x * (v % 3 + 1) + 0.2f * y * (l % 2 + 1));
    return Eigen::Vector3f(1.0f + s + 0.05f * g(rng), 0.5f + 0.3f * s, 0.2f + 0.01f * g(rng));
  });
}

TEST(BtfCompression, BandsOfAnySizeGiveTheSameFactors) {
  // Every case of the streamed matrix -- paper 384 x 6 and 96 x 6, per_texel
  // 64 x 36 (all tall) and 16 x 36 (wide, streamed as A^T) -- in one band,
  // and in bands of one texture line or one column: the same spectrum and
  // reconstruction up to rounding.
  for (const int size : {8, 4}) {
    const core::FullBtf btf =
        RandomSmoothBtf(size, core::SamplingSet::Named("grid3x2"), core::SamplingSet::Named("grid3x2"), 5);
    for (const core::BtfFactorLayout layout : {core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel}) {
      BtfCompressionOptions whole = Options(layout, core::BtfFactorColor::kYCbCr, 5);
      BtfCompressionOptions banded = whole;
      banded.band_bytes = 1;
      BtfCompressionReport rw, rb;
      const core::FactoredBtf fw = CompressBtf(btf, whole, &rw);
      const core::FactoredBtf fb = CompressBtf(btf, banded, &rb);
      for (int ch = 0; ch < 3; ++ch) {
        ASSERT_EQ(rw.singular_values[ch].size(), rb.singular_values[ch].size());
        for (long long k = 0; k < rw.singular_values[ch].size(); ++k) {
          EXPECT_NEAR(rb.singular_values[ch][k], rw.singular_values[ch][k], 1e-12 * rw.singular_values[ch][0])
              << "size " << size << " layout " << ToString(layout) << " ch " << ch << " k " << k;
        }
      }
      EXPECT_LT(MaxAbsDifference(fw, fb), 1e-5) << "size " << size << " layout " << ToString(layout);
      EXPECT_NEAR(rb.measured_relative_rms_error, rw.measured_relative_rms_error, 1e-9);
    }
  }
}

// A material package at `dir` holding `btf` as its full BTF.
void WriteFullBtfPackage(const std::filesystem::path& dir, const core::FullBtf& btf) {
  formats::MaterialDescription d;
  d.name = "full BTF";
  d.width = btf.width;
  d.height = btf.height;
  d.physical_size_mm = {4.0, 4.0};
  d.d_max_mm = 1.0;
  d.view_directions = btf.views;
  d.light_directions = btf.lights;
  formats::MaterialPackageWriter writer(dir, d, false);
  for (int v = 0; v < btf.view_count(); ++v) writer.WriteFullBtfView(v, btf.view_images[v]);
  writer.Commit();
}

TEST(BtfCompression, StreamsAPackagesViewFilesWithoutReadingThemWhole) {
  testing::TemporaryDirectory dir;
  const core::FullBtf btf =
      RandomSmoothBtf(8, core::SamplingSet::Named("grid3x2"), core::SamplingSet::Named("grid3x1"), 9);
  WriteFullBtfPackage(dir / "pkg", btf);
  BtfCompressionOptions o = Options(core::BtfFactorLayout::kPaper, core::BtfFactorColor::kRgb, 4);
  const core::FactoredBtf in_memory = CompressBtf(btf, o);
  o.band_bytes = 1;  // one texture line of every view file at a time
  formats::PackageFullBtfReader reader(dir / "pkg", formats::ReadMaterialManifest(dir / "pkg"));
  BtfCompressionReport report;
  const core::FactoredBtf streamed = CompressBtf(reader, o, &report);
  EXPECT_LT(MaxAbsDifference(in_memory, streamed), 1e-5);
  EXPECT_NEAR(report.measured_relative_rms_error, RelativeRmsError(btf, in_memory), 1e-9);

  // Compressing the package as it now is fails with an error naming every
  // part. Without its checksums (a version 1 package), so that the view
  // file's own checks are what refuses it.
  auto expect_error_naming = [&](std::initializer_list<std::string> parts) {
    formats::MaterialManifest unchecked = formats::ReadMaterialManifest(dir / "pkg");
    unchecked.checksums.clear();
    formats::PackageFullBtfReader reader(dir / "pkg", unchecked);
    try {
      CompressBtf(reader, o);
      FAIL() << "expected an error";
    } catch (const core::Error& e) {
      for (const std::string& part : parts) EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    }
  };
  // A non-finite value in a view file: the error names the file, texel and
  // light.
  core::Image bad = btf.view_images[4];
  bad.pixel(2, 8 * 1 + 5)[2] = std::numeric_limits<float>::infinity();
  core::WriteImage(dir / "pkg" / formats::FullBtfViewFile(4), bad);
  expect_error_naming({"view_0004.exr", "texel (2, 5), light 1, channel 2"});
  {
    formats::PackageFullBtfReader reader(dir / "pkg", formats::ReadMaterialManifest(dir / "pkg"));
    EXPECT_THROW(CompressBtf(reader, o), core::FormatError) << "its checksum differs";
  }
  // A view file of another size: named before any value is used.
  core::WriteImage(dir / "pkg" / formats::FullBtfViewFile(2), core::Image(8, 8, 3));
  expect_error_naming({"view_0002.exr", "height"});
}

// A choice of representation reads a package's BTF once and holds it (the
// clustered layout among those tried): it picks what the same BTF in
// memory picks, with the same factors.
TEST(BtfCompression, AChoiceFromAPackageMatchesTheSameBtfInMemory) {
  testing::TemporaryDirectory dir;
  const core::FullBtf btf =
      RandomSmoothBtf(8, core::SamplingSet::Named("grid3x2"), core::SamplingSet::Named("grid3x1"), 11);
  WriteFullBtfPackage(dir / "pkg", btf);
  for (const double budget : {0.01, 0.1}) {
    BtfCompressionOptions o;
    o.layout.reset();
    o.color.reset();
    o.max_relative_error = budget;
    BtfCompressionReport held_report, in_memory_report;
    const core::FactoredBtf in_memory = CompressBtf(btf, o, &in_memory_report);
    formats::PackageFullBtfReader reader(dir / "pkg", formats::ReadMaterialManifest(dir / "pkg"));
    const core::FactoredBtf held = CompressBtf(reader, o, &held_report);
    EXPECT_EQ(held.layout, in_memory.layout) << budget;
    EXPECT_EQ(held.color, in_memory.color) << budget;
    EXPECT_EQ(held.rank(), in_memory.rank()) << budget;
    EXPECT_EQ(held_report.candidates.size(), in_memory_report.candidates.size()) << budget;
    EXPECT_LT(MaxAbsDifference(held, in_memory), 1e-6) << budget;
    EXPECT_LE(held_report.measured_relative_rms_error, budget);
    EXPECT_TRUE(std::any_of(held_report.candidates.begin(), held_report.candidates.end(), [](const auto& c) {
      return c.layout == core::BtfFactorLayout::kClustered && c.rank > 0;
    })) << "the clustered layout is tried on a package's BTF";
  }
}

}  // namespace
}  // namespace mesocap::btf
