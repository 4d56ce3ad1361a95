// Round trips of material packages through the Bonn forms against the
// simulated rig's exact BTF, within each form's quantization:
//   DFMF / FMF, float factors: float rounding of the products (1e-5 relative
//     to the sum of |terms|);
//   DFMF / FMF, half factors: each factor value within 2^-11 relative, so a
//     reconstructed value within (2 * 2^-11 + 2^-22) sum_k |u_k s_k| (plus
//     float rounding and the 2^-25 absolute error of subnormals);
//   UBO2003 8-bit sRGB: half the local code step; EXR half: 2^-11 relative.
// Plus the other matrix orientation, the cosine flag and the PCA mean
// against hand-made files. The package-level jobs (export and import) are
// tested in tests/pipelines/bonn_jobs_test.cc.
#include "interop/bonn/bonn_interop.h"

#include <OpenImageIO/color.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

#include "btf/ambient_term.h"
#include "btf/btf_compression.h"
#include "interop/bonn/ubo_sampling_sets.h"
#include "sim/ground_truth.h"
#include "sim/mesostructure_scene.h"
#include "tests/bonn/bonn_round_trip.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::bonn {
namespace {

using testing::TermSum;
using testing::TrueBtf;
using testing::WorstRatio;

TEST(BonnInterop, DfmfRoundTripFromPerTexelFactors) {
  const core::FullBtf& truth = TrueBtf();
  btf::BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.rank = 24;  // full rank (24 texels): the factors reproduce the BTF exactly
  const core::FactoredBtf factored = btf::CompressBtf(truth, o);
  const BonnBtfFile written = BonnDfmfFromFactored(factored);
  testing::TemporaryDirectory dir;
  for (BonnScalar scalar : {BonnScalar::kFloat, BonnScalar::kHalf}) {
    WriteBonnBtfFile(dir / "a.btf", written, scalar);
    const BonnBtfFile read = ReadBonnBtfFile(dir / "a.btf");
    const core::FactoredBtf back = FactoredFromBonn(read, dir / "a.btf");
    EXPECT_EQ(back.layout, core::BtfFactorLayout::kPerTexel);
    EXPECT_EQ(back.rank(), 24);
    const double relative = scalar == BonnScalar::kHalf ? 2 * std::ldexp(1.0, -11) + std::ldexp(1.0, -22) : 0.0;
    const double ratio = WorstRatio(truth, [&](int v) { return btf::ReconstructBtfView(back, v); },
                                    [&](int x, int y, int v, int l, int c) {
                                      return (relative + 2e-6) * TermSum(written, x, y, v, l, c) + 1e-6;
                                    });
    EXPECT_LE(ratio, 1.0) << (scalar == BonnScalar::kHalf ? "half" : "float");
    // btflib's decode path (the full BTF) agrees with the factored import.
    const double decode = WorstRatio(truth, [&](int v) { return BonnBtfView(read, v); },
                                     [&](int x, int y, int v, int l, int c) {
                                       return (relative + 2e-6) * TermSum(written, x, y, v, l, c) + 1e-6;
                                     });
    EXPECT_LE(decode, 1.0);
  }
}

TEST(BonnInterop, DfmfDecorrelatedChannelsAreThePcaModel) {
  const core::FullBtf& truth = TrueBtf();
  btf::BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.color = core::BtfFactorColor::kYCbCr;
  o.rank = 24;
  const core::FactoredBtf factored = btf::CompressBtf(truth, o);
  const BonnBtfFile written = BonnDfmfFromFactored(factored);
  EXPECT_EQ(written.color_model, kBonnColorPca);
  testing::TemporaryDirectory dir;
  WriteBonnBtfFile(dir / "a.btf", written, BonnScalar::kFloat);
  const core::FactoredBtf back = FactoredFromBonn(ReadBonnBtfFile(dir / "a.btf"), dir / "a.btf");
  EXPECT_EQ(back.color, core::BtfFactorColor::kYCbCr);
  EXPECT_TRUE(back.rgb_to_factored.isApprox(factored.rgb_to_factored, 1e-6));
  // The colour matrix passes through float: 1e-6 of the channel terms.
  const double ratio = WorstRatio(truth, [&](int v) { return btf::ReconstructBtfView(back, v); },
                                  [&](int x, int y, int v, int l, int) {
                                    double s = 0;
                                    for (int c = 0; c < 3; ++c) s += TermSum(written, x, y, v, l, c);
                                    return 1e-5 * s + 1e-6;
                                  });
  EXPECT_LE(ratio, 1.0);
}

TEST(BonnInterop, FmfRoundTripOfAFullBtf) {
  const core::FullBtf& truth = TrueBtf();
  btf::BtfCompressionOptions o;
  o.rank = 48;  // full rank: min(3 x 24 rows, 48 directions)
  btf::BtfCompressionReport report;
  const BonnBtfFile written = BonnFmfFromFullBtf(truth, o, &report);
  EXPECT_EQ(report.rank, 48);
  EXPECT_LT(report.measured_relative_rms_error, 1e-5);
  ASSERT_EQ(written.factors.size(), 1u);
  EXPECT_EQ(written.factors[0].u.rows(), 3 * 24);
  testing::TemporaryDirectory dir;
  for (BonnScalar scalar : {BonnScalar::kFloat, BonnScalar::kHalf}) {
    WriteBonnBtfFile(dir / "a.btf", written, scalar);
    const BonnBtfFile read = ReadBonnBtfFile(dir / "a.btf");
    EXPECT_EQ(read.form, BonnBtfForm::kFmf);
    const core::FactoredBtf back = FactoredFromBonn(read, dir / "a.btf");
    const double relative = scalar == BonnScalar::kHalf ? 2 * std::ldexp(1.0, -11) + std::ldexp(1.0, -22) : 0.0;
    auto bound = [&](int x, int y, int v, int l, int c) {
      return (relative + 1e-5) * TermSum(written, x, y, v, l, c) + 1e-6;
    };
    EXPECT_LE(WorstRatio(truth, [&](int v) { return btf::ReconstructBtfView(back, v); }, bound), 1.0);
    EXPECT_LE(WorstRatio(truth, [&](int v) { return BonnBtfView(read, v); }, bound), 1.0);
  }
  // A lower rank: the error is the truncation the report states.
  o.rank = 0;
  o.max_relative_error = 0.05;
  const BonnBtfFile truncated = BonnFmfFromFullBtf(truth, o, &report);
  EXPECT_LT(report.rank, 48);
  EXPECT_LE(report.measured_relative_rms_error, 0.05);
  EXPECT_EQ(truncated.factors[0].rank(), report.rank);
}

// The same BTF as a file with the other orientation (U rows = directions),
// the light cosine multiplied in, and a PCA mean: all decode to the same.
TEST(BonnInterop, OrientationCosineAndMeanAreUndone) {
  const core::FullBtf& truth = TrueBtf();
  btf::BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.rank = 24;
  const BonnBtfFile base = BonnDfmfFromFactored(btf::CompressBtf(truth, o));
  const std::filesystem::path name = "test.btf";

  BonnBtfFile swapped = base;
  swapped.row_space = BonnRowSpace::kDirections;
  for (auto& f : swapped.factors) std::swap(f.u, f.sxv);
  // Cosine flag: the file holds T cos(theta_l).
  swapped.cosine_flag = true;
  for (auto& f : swapped.factors)
    for (int j = 0; j < f.u.rows(); ++j) f.u.row(j) *= std::cos(swapped.lights[j % swapped.light_count()].theta);
  // PCA with identity matrix and mean m, decoded as btflib does, (f + m) /
  // cos(theta_l) = T: store f = T cos - m as the factors above plus one
  // component of -m.
  const Eigen::Vector3f mean(0.05f, -0.02f, 0.1f);
  swapped.color_model = kBonnColorPca;
  swapped.color_mean = mean;
  for (int c = 0; c < 3; ++c) {
    BonnFactors& f = swapped.factors[c];
    const int k = f.rank();
    f.u.conservativeResize(Eigen::NoChange, k + 1);
    f.sxv.conservativeResize(Eigen::NoChange, k + 1);
    f.singular_values.conservativeResize(k + 1);
    f.u.col(k).setConstant(-mean[c]);
    f.sxv.col(k).setOnes();
    f.singular_values[k] = 0.0f;
  }
  const core::FactoredBtf back = FactoredFromBonn(swapped, name);
  EXPECT_EQ(back.rank(), 26);  // 25 stored + the mean
  auto bound = [&](int x, int y, int v, int l, int c) { return 1e-5 * TermSum(base, x, y, v, l, c) + 2e-6; };
  EXPECT_LE(WorstRatio(truth, [&](int v) { return btf::ReconstructBtfView(back, v); }, bound), 1.0);
  EXPECT_LE(WorstRatio(truth, [&](int v) { return BonnBtfView(swapped, v); }, bound), 1.0);

  // Nonlinear decodes cannot be factored: a clear refusal naming the model.
  BonnBtfFile log_model = base;
  log_model.color_model = 12;
  try {
    FactoredFromBonn(log_model, name);
    FAIL();
  } catch (const core::FormatError& e) {
    EXPECT_EQ(e.field(), "color_model");
    EXPECT_NE(std::string(e.what()).find("log RGB"), std::string::npos);
  }
}

TEST(BonnInterop, Ubo2014DomeIsRecognised) {
  BonnBtfFile b;
  const core::SamplingSet dome = NamedSamplingSet("ubo2014");
  for (int i = 0; i < dome.size(); ++i) b.views.push_back(BonnFromAngles(dome.angles(i)));
  const core::SamplingSet set = BonnViewSet(b, "x.btf");
  EXPECT_EQ(set.name(), "ubo2014");
  EXPECT_EQ(set.angles(7).phi, dome.angles(7).phi);  // the named set's exact angles
  b.views[3].theta += 0.01f;
  EXPECT_EQ(BonnViewSet(b, "x.btf").name(), "bonn_file");
}

}  // namespace
}  // namespace mesocap::bonn
