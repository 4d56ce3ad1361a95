// Round trips of material packages through the Bonn forms against the
// simulated rig's exact BTF, within each form's quantization:
//   DFMF / FMF, float factors: float rounding of the products (1e-5 relative
//     to the sum of |terms|);
//   DFMF / FMF, half factors: each factor value within 2^-11 relative, so a
//     reconstructed value within (2 * 2^-11 + 2^-22) sum_k |u_k s_k| (plus
//     float rounding and the 2^-25 absolute error of subnormals);
//   UBO2003 8-bit sRGB: half the local code step; EXR half: 2^-11 relative.
// Plus the other matrix orientation, the cosine flag and the PCA mean
// against hand-made files, and package-level failures leaving nothing.
#include "interop/bonn/bonn_interop.h"

#include <OpenImageIO/color.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

#include "btf/ambient_term.h"
#include "btf/btf_compression.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "sim/ground_truth.h"
#include "sim/mesostructure_scene.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::bonn {
namespace {

// The exact BTF of the `blocks` scene on a 6 x 4 texture (not square, so a
// swapped x and y shows) with 8 views and 6 lights.
const core::FullBtf& TrueBtf() {
  static const core::FullBtf btf = [] {
    sim::GroundTruthOptions gt;
    gt.texture_width = 6;
    gt.texture_height = 4;
    gt.sample_size_mm = 12.0;
    gt.views = core::SamplingSet::Named("grid4x2");
    gt.lights = core::SamplingSet::Named("grid3x2");
    return sim::RenderTrueBtf(*sim::MakeBuiltinScene("blocks"), gt);
  }();
  return btf;
}

formats::MaterialPackage PackageOf(const core::FullBtf& btf) {
  formats::MaterialPackage p;
  p.description.name = "blocks";
  p.description.width = btf.width;
  p.description.height = btf.height;
  p.description.physical_size_mm = {12.0, 8.0};
  p.description.d_max_mm = 1.5;
  p.description.view_directions = btf.views;
  p.description.light_directions = btf.lights;
  p.full_btf = btf;
  return p;
}

// Largest |a - b| / bound over every value, bound(x, y, v, l, c) given.
template <typename Bound>
double WorstRatio(const core::FullBtf& want, const std::function<core::Image(int)>& got_view, Bound bound) {
  double worst = 0.0;
  for (int v = 0; v < want.view_count(); ++v) {
    const core::Image got = got_view(v);
    for (int l = 0; l < want.light_count(); ++l)
      for (int y = 0; y < want.height; ++y)
        for (int x = 0; x < want.width; ++x)
          for (int c = 0; c < 3; ++c) {
            const double d = std::abs(got.at(x, l * want.height + y, c) - want.at(x, y, v, l)[c]);
            worst = std::max(worst, d / bound(x, y, v, l, c));
          }
  }
  return worst;
}

// sum_k |U| |SxV| of one value of a texel-rows Bonn file: what bounds the
// rounding of its factors.
double TermSum(const BonnBtfFile& b, int x, int y, int v, int l, int c) {
  const int t = x + b.width * y, j = l + b.light_count() * v;
  const BonnFactors& f = b.factors[b.form == BonnBtfForm::kFmf ? 0 : c];
  const int row = b.form == BonnBtfForm::kFmf ? c + 3 * t : t;
  return (f.u.row(row).cwiseAbs().array() * f.sxv.row(j).cwiseAbs().array()).sum();
}

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
  const core::SamplingSet dome = core::SamplingSet::Named("ubo2014");
  for (int i = 0; i < dome.size(); ++i) b.views.push_back(BonnFromAngles(dome.angles(i)));
  const core::SamplingSet set = BonnViewSet(b, "x.btf");
  EXPECT_EQ(set.name(), "ubo2014");
  EXPECT_EQ(set.angles(7).phi, dome.angles(7).phi);  // the named set's exact angles
  b.views[3].theta += 0.01f;
  EXPECT_EQ(BonnViewSet(b, "x.btf").name(), "bonn_file");
}

TEST(BonnInterop, PackageRoundTripsThroughEveryForm) {
  testing::TemporaryDirectory dir;
  const core::FullBtf& truth = TrueBtf();
  formats::WriteMaterialPackage(dir / "in", PackageOf(truth), false);

  BonnImportOptions import;
  import.d_max_mm = 1.5;
  import.flat_mdf = true;

  // UBO2003, 8-bit sRGB: within half a code step (the values are below 1).
  BonnExportOptions png;
  png.form = BonnForm::kUbo2003;
  const BonnExportReport r = ExportBonn(dir / "in", dir / "ubo", png);
  EXPECT_EQ(r.files, 8 * 6);
  EXPECT_EQ(r.clipped_values, 0);
  import.width_mm = 12.0;
  const BonnImportReport ir = ImportBonn(dir / "ubo", dir / "from_ubo", import);
  EXPECT_TRUE(ir.manifest.full_btf);
  EXPECT_TRUE(ir.manifest.ambient);
  EXPECT_TRUE(ir.manifest.mdf.has_value());
  EXPECT_NEAR(ir.manifest.description.physical_size_mm.y(), 8.0, 1e-12);
  const core::FullBtf from_ubo = formats::ReadFullBtf(dir / "from_ubo", ir.manifest);
  // The folder scan orders directions ring by ring; the grid sets are in that order.
  for (int v = 0; v < truth.view_count(); ++v) {
    EXPECT_NEAR(from_ubo.views.angles(v).theta, truth.views.angles(v).theta, 1e-9);
    EXPECT_NEAR(from_ubo.views.angles(v).phi, truth.views.angles(v).phi, 1e-9);
  }
  const double srgb = WorstRatio(truth, [&](int v) { return from_ubo.view_images[v]; },
                                 [&](int x, int y, int v, int l, int c) {
                                   const float w = truth.at(x, y, v, l)[c];
                                   const float code = std::round(OIIO::linear_to_sRGB(w) * 255.0f);
                                   return 0.5 * (OIIO::sRGB_to_linear(std::min(code + 1, 255.0f) / 255.0f) -
                                                 OIIO::sRGB_to_linear(std::max(code - 1, 0.0f) / 255.0f)) +
                                          1e-6;
                                 });
  EXPECT_LE(srgb, 1.0);

  // DFMF from a full BTF (factored here at full rank), half, imported factored.
  BonnExportOptions dfmf;
  dfmf.form = BonnForm::kDfmf;
  dfmf.compression.rank = 24;
  const BonnExportReport dr = ExportBonn(dir / "in", dir / "a.dfmf", dfmf);
  EXPECT_EQ(dr.rank, 24);
  import.width_mm = 0.0;  // from the file's pixels per mm
  const BonnImportReport di = ImportBonn(dir / "a.dfmf", dir / "from_dfmf", import);
  EXPECT_EQ(di.rank, 24);
  EXPECT_NEAR(di.manifest.description.physical_size_mm.x(), 12.0, 1e-5);
  const core::FactoredBtf from_dfmf = formats::ReadFactoredBtf(dir / "from_dfmf", di.manifest);
  const BonnBtfFile dfile = ReadBonnBtfFile(dir / "a.dfmf");
  EXPECT_LE(WorstRatio(truth, [&](int v) { return btf::ReconstructBtfView(from_dfmf, v); },
                       [&](int x, int y, int v, int l, int c) {
                         return (2.1 * std::ldexp(1.0, -11) + 2e-6) * TermSum(dfile, x, y, v, l, c) + 1e-6;
                       }),
            1.0);
  // The ambient term is the truth's (processing/ambient_term.h) within the
  // quantization integrated over the lights: sum_l cos(theta_l) w_l <= pi.
  const formats::AmbientTerm ambient = formats::ReadAmbientTerm(dir / "from_dfmf", di.manifest);
  const formats::AmbientTerm true_ambient = btf::ComputeAmbientTerm(truth);
  double largest_term_sum = 0.0;
  for (int v = 0; v < truth.view_count(); ++v)
    for (int l = 0; l < truth.light_count(); ++l)
      for (int y = 0; y < truth.height; ++y)
        for (int x = 0; x < truth.width; ++x)
          for (int c = 0; c < 3; ++c) largest_term_sum = std::max(largest_term_sum, TermSum(dfile, x, y, v, l, c));
  const double ambient_bound = std::numbers::pi * ((2.1 * std::ldexp(1.0, -11) + 2e-6) * largest_term_sum + 1e-6);
  ASSERT_EQ(ambient.values.size(), true_ambient.values.size());
  for (std::size_t i = 0; i < ambient.values.size(); ++i) {
    EXPECT_NEAR(ambient.values.data()[i], true_ambient.values.data()[i], ambient_bound) << i;
  }

  // FMF, float, imported as both forms.
  BonnExportOptions fmf;
  fmf.form = BonnForm::kFmf;
  fmf.scalar = BonnScalar::kFloat;
  fmf.compression.rank = 48;
  ExportBonn(dir / "in", dir / "a.fmf", fmf);
  import.parts = BonnImportParts::kBoth;
  const BonnImportReport fi = ImportBonn(dir / "a.fmf", dir / "from_fmf", import);
  EXPECT_TRUE(fi.manifest.full_btf);
  EXPECT_EQ(fi.rank, 48);
  const core::FullBtf from_fmf = formats::ReadFullBtf(dir / "from_fmf", fi.manifest);
  const BonnBtfFile ffile = ReadBonnBtfFile(dir / "a.fmf");
  EXPECT_LE(WorstRatio(truth, [&](int v) { return from_fmf.view_images[v]; },
                       [&](int x, int y, int v, int l, int c) { return 1e-5 * TermSum(ffile, x, y, v, l, c) + 1e-6; }),
            1.0);
}

TEST(BonnInterop, FailuresLeaveNothingBehind) {
  testing::TemporaryDirectory dir;
  core::FullBtf big = TrueBtf();
  big.view_images[2].at(1, 1, 0) = 1e6f;  // does not fit a half
  formats::WriteMaterialPackage(dir / "in", PackageOf(big), false);

  BonnExportOptions exr;
  exr.form = BonnForm::kUbo2003;
  exr.encoding = Ubo2003Encoding::kHalfExr;
  EXPECT_THROW(ExportBonn(dir / "in", dir / "ubo", exr), core::Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "ubo"));

  BonnExportOptions dfmf;
  dfmf.form = BonnForm::kDfmf;
  dfmf.compression.rank = 24;
  EXPECT_THROW(ExportBonn(dir / "in", dir / "a.dfmf", dfmf), core::Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "a.dfmf"));

  // An existing target is kept unless --replace.
  std::filesystem::create_directories(dir / "taken");
  BonnExportOptions png;
  png.form = BonnForm::kUbo2003;
  EXPECT_THROW(ExportBonn(dir / "in", dir / "taken", png), core::Error);
  dfmf.scalar = BonnScalar::kFloat;
  ExportBonn(dir / "in", dir / "a.dfmf", dfmf);
  EXPECT_THROW(ExportBonn(dir / "in", dir / "a.dfmf", dfmf), core::Error);

  // Import of a truncated file: FormatError, no package.
  std::filesystem::resize_file(dir / "a.dfmf", std::filesystem::file_size(dir / "a.dfmf") - 7);
  BonnImportOptions import;
  import.d_max_mm = 1.0;
  EXPECT_THROW(ImportBonn(dir / "a.dfmf", dir / "out", import), core::FormatError);
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
  // An image folder cannot be imported factored, nor without a size.
  ExportBonn(dir / "in", dir / "ubo", png);
  import.parts = BonnImportParts::kFactored;
  import.width_mm = 10;
  EXPECT_THROW(ImportBonn(dir / "ubo", dir / "out", import), core::Error);
  import.parts.reset();
  import.width_mm = 0;
  EXPECT_THROW(ImportBonn(dir / "ubo", dir / "out", import), core::Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));
}

}  // namespace
}  // namespace mesocap::bonn
