// The Bonn binary BTF files (UBO2014 FMF / DFMF): direction conversion
// against analytic cases, byte-exact write/read round trips (float) and
// within half-float rounding (half), and bad files: wrong signature,
// truncation at every field, inconsistent counts, trailing bytes.
#include "interop/bonn/bonn_btf_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <numbers>

#include "core/error.h"
#include "tests/common/largest_allocation.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::bonn {
namespace {

constexpr double kPi = std::numbers::pi;

std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}
void Spit(const std::filesystem::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}
template <typename T>
void Patch(std::string* bytes, std::size_t offset, T value) {
  std::memcpy(bytes->data() + offset, &value, sizeof value);
}

// A small DFMF in the database's orientation (U rows = 6 directions, SxV
// rows = 8 texels): 4 x 2 texels, 2 views x 3 lights, ranks 2, 1, 2.
BonnBtfFile SmallDfmf() {
  BonnBtfFile b;
  b.form = BonnBtfForm::kDfmf;
  b.row_space = BonnRowSpace::kDirections;
  b.measurement_setup = "test dome";
  b.pixels_per_mm = 4.0f;
  b.xml = "<measurement/>";
  b.width = 4;
  b.height = 2;
  b.views = {{0.0f, 0.0f}, {0.5f, -2.0f}};
  b.lights = {{0.0f, 0.0f}, {0.3f, 1.0f}, {1.2f, 3.0f}};
  b.color_model = kBonnColorPca;
  b.color_mean = {0.1f, 0.2f, 0.3f};
  b.color_matrix << 1, 0.5f, 0, 0, 1, 0.25f, 0.125f, 0, 1;
  const int ranks[3] = {2, 1, 2};
  for (int c = 0; c < 3; ++c) {
    BonnFactors f;
    f.singular_values = Eigen::VectorXf::LinSpaced(ranks[c], 3.0f, 1.0f);
    f.u = BonnMatrix::Random(6, ranks[c]);
    f.sxv = BonnMatrix::Random(8, ranks[c]) * 10.0f;
    b.factors.push_back(f);
  }
  return b;
}

TEST(BonnDirections, AnalyticCases) {
  // btflib's sph2cart2: (sin t cos p, sin t sin p, cos t), the same formula
  // as mesocap's DirectionFromAngles, so only phi's range differs.
  const core::SphericalAngles a = AnglesFromBonn({static_cast<float>(kPi / 4), static_cast<float>(-kPi / 2)});
  EXPECT_NEAR(a.theta, kPi / 4, 1e-7);
  EXPECT_NEAR(a.phi, 3 * kPi / 2, 1e-7);
  const Eigen::Vector3d d = core::DirectionFromAngles(a.theta, a.phi);
  EXPECT_NEAR(d.x(), 0.0, 1e-7);
  EXPECT_NEAR(d.y(), -std::sqrt(0.5), 1e-7);
  EXPECT_NEAR(d.z(), std::sqrt(0.5), 1e-7);
  // mesocap -> Bonn gives atan2's range (-pi, pi].
  const BonnDirection b = BonnFromAngles({kPi / 3, 3 * kPi / 2});
  EXPECT_NEAR(b.theta, kPi / 3, 1e-7);
  EXPECT_NEAR(b.phi, -kPi / 2, 1e-7);
  EXPECT_NEAR(BonnFromAngles({0.2, kPi}).phi, kPi, 1e-6);
  EXPECT_NEAR(BonnFromAngles({0.2, 0.25}).phi, 0.25, 1e-7);
  // Wrapping: phi = 7 pi / 2 is 3 pi / 2; at the pole phi is 0 (mesocap).
  EXPECT_NEAR(AnglesFromBonn({0.5f, static_cast<float>(3.5 * kPi)}).phi, 1.5 * kPi, 1e-6);
  EXPECT_EQ(AnglesFromBonn({0.0f, 2.0f}).phi, 0.0);
  // Round trip through the file's floats: within float rounding (~1e-7 rad).
  for (double theta : {0.1, 0.7, 1.5})
    for (double phi : {0.0, 1.0, 3.0, 4.0, 6.2}) {
      const core::SphericalAngles back = AnglesFromBonn(BonnFromAngles({theta, phi}));
      EXPECT_NEAR(back.theta, theta, 1e-7);
      EXPECT_NEAR(std::remainder(back.phi - phi, 2 * kPi), 0.0, 1e-6);
    }
}

TEST(BonnBtfFile, FloatRoundTripIsExact) {
  testing::TemporaryDirectory dir;
  const BonnBtfFile b = SmallDfmf();
  WriteBonnBtfFile(dir / "a.btf", b, BonnScalar::kFloat);
  const BonnBtfFile r = ReadBonnBtfFile(dir / "a.btf");
  EXPECT_EQ(r.form, BonnBtfForm::kDfmf);
  EXPECT_EQ(r.signature, "!DFMF08FCR");
  EXPECT_EQ(r.measurement_setup, "test dome");
  EXPECT_EQ(r.xml, "<measurement/>");
  EXPECT_EQ(r.pixels_per_mm, 4.0f);
  EXPECT_EQ(r.width, 4);
  EXPECT_EQ(r.height, 2);
  ASSERT_EQ(r.view_count(), 2);
  ASSERT_EQ(r.light_count(), 3);
  EXPECT_EQ(r.views[1].phi, -2.0f);
  EXPECT_EQ(r.lights[2].theta, 1.2f);
  EXPECT_EQ(r.color_model, kBonnColorPca);
  EXPECT_EQ(r.color_mean, b.color_mean);
  EXPECT_EQ(r.color_matrix, b.color_matrix);
  EXPECT_EQ(r.row_space, BonnRowSpace::kDirections);
  EXPECT_EQ(r.scalar, BonnScalar::kFloat);
  ASSERT_EQ(r.factors.size(), 3u);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(r.factors[c].u, b.factors[c].u);
    EXPECT_EQ(r.factors[c].sxv, b.factors[c].sxv);
    EXPECT_EQ(r.factors[c].singular_values, b.factors[c].singular_values);
  }
}

TEST(BonnBtfFile, HalfRoundTripIsWithinHalfRounding) {
  testing::TemporaryDirectory dir;
  BonnBtfFile b = SmallDfmf();
  b.form = BonnBtfForm::kFmf;  // one matrix, channels in the rows: 3 * 6 directions x 8 texels
  b.factors = {BonnFactors{Eigen::VectorXf::Constant(3, 1.0f), BonnMatrix::Random(18, 3) * 0.01f,
                           BonnMatrix::Random(8, 3) * 300.0f}};
  b.dynamic_range_reduction = 0;
  WriteBonnBtfFile(dir / "a.btf", b, BonnScalar::kHalf);
  const BonnBtfFile r = ReadBonnBtfFile(dir / "a.btf");
  EXPECT_EQ(r.form, BonnBtfForm::kFmf);
  EXPECT_EQ(r.signature, "!FMF12FCER");
  EXPECT_EQ(r.scalar, BonnScalar::kHalf);
  EXPECT_EQ(r.row_space, BonnRowSpace::kDirections);
  // Half keeps 11 significant bits: relative error <= 2^-11 for normal
  // values (|v| >= 2^-14), absolute <= 2^-25 below.
  auto expect_half = [](const BonnMatrix& got, const BonnMatrix& want) {
    ASSERT_EQ(got.rows(), want.rows());
    for (Eigen::Index i = 0; i < want.size(); ++i) {
      const float w = want.data()[i];
      EXPECT_LE(std::abs(got.data()[i] - w), std::max(std::abs(w) * std::ldexp(1.0f, -11), std::ldexp(1.0f, -25))) << i;
    }
  };
  expect_half(r.factors[0].u, b.factors[0].u);
  expect_half(r.factors[0].sxv, b.factors[0].sxv);
}

// What mesocap wrote before (and btflib also reads): U rows = texels.
TEST(BonnBtfFile, TexelRowsAreRead) {
  testing::TemporaryDirectory dir;
  BonnBtfFile b = SmallDfmf();
  b.row_space = BonnRowSpace::kTexels;
  for (auto& f : b.factors) std::swap(f.u, f.sxv);
  WriteBonnBtfFile(dir / "a.btf", b, BonnScalar::kFloat);
  BonnBtfFile r = ReadBonnBtfFile(dir / "a.btf");
  EXPECT_EQ(r.row_space, BonnRowSpace::kTexels);
  EXPECT_EQ(r.factors[2].u, b.factors[2].u);
  EXPECT_EQ(r.factors[2].sxv, b.factors[2].sxv);
  // FMF: U rows channel + 3 * texel.
  b.form = BonnBtfForm::kFmf;
  b.factors = {BonnFactors{Eigen::VectorXf::Ones(2), BonnMatrix::Random(24, 2), BonnMatrix::Random(6, 2)}};
  WriteBonnBtfFile(dir / "b.btf", b, BonnScalar::kFloat);
  r = ReadBonnBtfFile(dir / "b.btf");
  EXPECT_EQ(r.row_space, BonnRowSpace::kTexels);
  EXPECT_EQ(r.factors[0].u, b.factors[0].u);
}

// Rule: when width x height = views x lights the counts cannot tell, and
// U's rows are directions (the database's orientation). The writer keeps
// to it: a texel-rows DFMF is written transposed, a texel-rows FMF refused.
TEST(BonnBtfFile, AmbiguousCountsAreDirectionRows) {
  // 3 x 2 texels = 2 views x 3 lights.
  testing::TemporaryDirectory dir;
  BonnBtfFile b = SmallDfmf();
  b.width = 3;
  for (auto& f : b.factors) f.sxv.conservativeResize(6, Eigen::NoChange);
  WriteBonnBtfFile(dir / "a.btf", b, BonnScalar::kFloat);
  BonnBtfFile r = ReadBonnBtfFile(dir / "a.btf");
  EXPECT_EQ(r.row_space, BonnRowSpace::kDirections);
  EXPECT_EQ(r.factors[1].u, b.factors[1].u);
  EXPECT_EQ(r.factors[1].sxv, b.factors[1].sxv);

  BonnBtfFile texel_rows = b;
  texel_rows.row_space = BonnRowSpace::kTexels;
  for (auto& f : texel_rows.factors) std::swap(f.u, f.sxv);
  WriteBonnBtfFile(dir / "b.btf", texel_rows, BonnScalar::kFloat);
  r = ReadBonnBtfFile(dir / "b.btf");
  EXPECT_EQ(r.row_space, BonnRowSpace::kDirections);
  EXPECT_EQ(r.factors[1].sxv, texel_rows.factors[1].u);  // the texel side, now SxV
  EXPECT_EQ(r.factors[1].u, texel_rows.factors[1].sxv);

  texel_rows.form = BonnBtfForm::kFmf;
  texel_rows.factors = {BonnFactors{Eigen::VectorXf::Ones(1), BonnMatrix::Random(18, 1), BonnMatrix::Random(6, 1)}};
  EXPECT_THROW(WriteBonnBtfFile(dir / "c.btf", texel_rows, BonnScalar::kFloat), core::Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "c.btf"));
  // The same FMF with direction rows is written and read as it is.
  texel_rows.row_space = BonnRowSpace::kDirections;
  WriteBonnBtfFile(dir / "c.btf", texel_rows, BonnScalar::kFloat);
  r = ReadBonnBtfFile(dir / "c.btf");
  EXPECT_EQ(r.row_space, BonnRowSpace::kDirections);
  EXPECT_EQ(r.factors[0].u, texel_rows.factors[0].u);
}

TEST(BonnBtfFile, HalfOverflowIsRefusedAndNothingWritten) {
  testing::TemporaryDirectory dir;
  BonnBtfFile b = SmallDfmf();
  b.factors[1].sxv(2, 0) = 1e5f;
  try {
    WriteBonnBtfFile(dir / "a.btf", b, BonnScalar::kHalf);
    FAIL();
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("65504"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

// Expects ReadBonnBtfFile to throw a FormatError for `file` naming `field`.
void ExpectBad(const std::filesystem::path& file, const std::string& field, const std::string& words) {
  try {
    ReadBonnBtfFile(file);
    FAIL() << "no error for " << field;
  } catch (const core::FormatError& e) {
    EXPECT_EQ(e.file(), file);
    EXPECT_NE(e.field().find(field), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
  }
}

TEST(BonnBtfFile, BadFilesNameTheFieldAndWhatWasExpected) {
  testing::TemporaryDirectory dir;
  WriteBonnBtfFile(dir / "good.btf", SmallDfmf(), BonnScalar::kHalf);
  const std::string good = Slurp(dir / "good.btf");
  const auto bad = dir / "bad.btf";

  std::string s = good;
  s.replace(0, 6, "!XYZ08");
  Spit(bad, s);
  ExpectBad(bad, "signature", "expected \"!FMF12FCER\"");

  // Offsets of this file's fields: signature 10, meta block, directions
  // (4 + 2 views x (8 + 4 + 3 lights x 8)), width, height, rotation count.
  std::uint32_t meta_size;
  std::memcpy(&meta_size, good.data() + 10, 4);
  const std::size_t directions = 10 + meta_size;
  const std::size_t after_header = directions + 4 + 2 * (8 + 4 + 3 * 8) + 12;
  const std::size_t channel0 = after_header + 4 + 4 + 12 + 36;

  s = good;
  Patch<std::uint32_t>(&s, 10, meta_size + 4);
  Spit(bad, s);
  ExpectBad(bad, "meta", "");

  s = good;
  Patch<std::uint32_t>(&s, directions + 4 + 8 + 4 + 3 * 8 + 8, 2);  // view 1's light count
  Spit(bad, s);
  ExpectBad(bad, "views[1].light_count", "expected the same light count");

  s = good;
  Patch<float>(&s, directions + 4, 2.0f);  // view 0's theta: below the horizon
  Spit(bad, s);
  ExpectBad(bad, "views[0].theta", "[0, pi/2)");

  // Matrix sizes that fit neither orientation: the rows, the columns, both
  // swapped against each other but with a wrong count.
  s = good;
  Patch<std::uint32_t>(&s, channel0 + 1 + 4, 7);  // channel 0's row count
  Spit(bad, s);
  ExpectBad(bad, "channels[0].rows",
            "expected lights x views = 6 rows and width x height = 8 columns (the database's orientation), or "
            "width x height = 8 rows and lights x views = 6 columns; got 7 x 8");
  s = good;
  Patch<std::uint32_t>(&s, channel0 + 1 + 8, 9);  // channel 0's column count
  Spit(bad, s);
  ExpectBad(bad, "channels[0].rows", "got 6 x 9");
  s = good;
  Patch<std::uint32_t>(&s, channel0 + 1 + 4, 8);
  Patch<std::uint32_t>(&s, channel0 + 1 + 8, 8);
  Spit(bad, s);
  ExpectBad(bad, "channels[0].rows", "got 8 x 8");

  // FMF: the channel is part of U's row count. Its rows follow the version
  // byte, the method, the height-map size and K, scalar size, K.
  BonnBtfFile fmf = SmallDfmf();
  fmf.form = BonnBtfForm::kFmf;
  fmf.factors = {BonnFactors{Eigen::VectorXf::Ones(1), BonnMatrix::Random(18, 1), BonnMatrix::Random(8, 1)}};
  WriteBonnBtfFile(dir / "good.fmf", fmf, BonnScalar::kHalf);
  s = Slurp(dir / "good.fmf");
  Patch<std::uint32_t>(&s, after_header + 1 + 4 + 8 + 4 + 1 + 4, 6);
  Spit(bad, s);
  ExpectBad(bad, "rows", "expected 3 x lights x views = 18 rows and width x height = 8 columns");

  s = good;
  Patch<std::uint8_t>(&s, channel0, 3);  // scalar size
  Spit(bad, s);
  ExpectBad(bad, "channels[0].scalar_size", "expected 2 (half)");

  s = good;
  Patch<std::uint32_t>(&s, channel0 + 1, 9);  // more components than the header's largest (2)
  Spit(bad, s);
  ExpectBad(bad, "channels[0].components", "expected 1..2");

  s = good + "junk";
  Spit(bad, s);
  ExpectBad(bad, "size", "bytes after the last factor matrix");

  // Cut anywhere: the field being read is named, with the bytes missing.
  for (std::size_t cut :
       {std::size_t{12}, std::size_t{100}, directions + 6, after_header - 2, channel0 + 3, good.size() - 1}) {
    Spit(bad, good.substr(0, cut));
    try {
      ReadBonnBtfFile(bad);
      FAIL() << "cut at " << cut;
    } catch (const core::FormatError& e) {
      EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << cut << ": " << e.what();
      EXPECT_FALSE(e.field().empty());
    }
  }
  EXPECT_THROW(ReadBonnBtfFile(dir / "missing.btf"), core::FormatError);
}

// A string length (the XML block's) beyond the file is refused before the
// string is allocated: a 1 KB file must not cost gigabytes.
TEST(BonnBtfFile, StringLengthBeyondTheFileIsRefusedBeforeAllocating) {
  testing::TemporaryDirectory dir;
  WriteBonnBtfFile(dir / "good.btf", SmallDfmf(), BonnScalar::kHalf);
  std::string s = Slurp(dir / "good.btf");
  // signature 10, meta size and version 8, three 80-char strings, pixels per
  // mm 4, RGB scale 12, cosine flag 4: then the XML length.
  Patch<std::uint32_t>(&s, 10 + 8 + 240 + 4 + 12 + 4, 0xfffffff0u);
  Spit(dir / "bad.btf", s);
  g_largest_allocation = 0;
  ExpectBad(dir / "bad.btf", "meta.xml", "truncated");
  EXPECT_LT(g_largest_allocation.load(), std::size_t{1} << 20);
}

TEST(BonnBtfFile, OlderFmfSignaturesAreRead) {
  // "!FMF06FCR" has no header-version byte (btflib's header flag false):
  // build one from a FMF12 file by dropping the version, the method and the
  // height-map size.
  testing::TemporaryDirectory dir;
  BonnBtfFile b = SmallDfmf();
  b.form = BonnBtfForm::kFmf;
  b.factors = {BonnFactors{Eigen::VectorXf::Ones(1), BonnMatrix::Random(18, 1), BonnMatrix::Random(8, 1)}};
  WriteBonnBtfFile(dir / "a.btf", b, BonnScalar::kFloat);
  std::string s = Slurp(dir / "a.btf");
  std::uint32_t meta_size;
  std::memcpy(&meta_size, s.data() + 10, 4);
  const std::size_t after_header = 10 + meta_size + 4 + 2 * (8 + 4 + 3 * 8) + 12;
  // u8 version + u32 method + u32[2] height-map size follow the common header.
  Spit(dir / "old.btf", "!FMF06FCR" + s.substr(10, after_header - 10) + s.substr(after_header + 13));
  const BonnBtfFile r = ReadBonnBtfFile(dir / "old.btf");
  EXPECT_EQ(r.signature, "!FMF06FCR");
  EXPECT_EQ(r.factors[0].u, b.factors[0].u);
}

TEST(BonnColorModels, LinearModelsAndRefusals) {
  BonnBtfFile b = SmallDfmf();
  b.color_model = kBonnColorYuv;
  // Y = 1, U = V = 0 is white.
  EXPECT_TRUE((BonnToRgb(b).to_rgb * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d::Ones()));
  b.color_model = kBonnColorYcocg;
  EXPECT_TRUE((BonnToRgb(b).to_rgb * Eigen::Vector3d(1, 0, 0)).isApprox(Eigen::Vector3d::Ones()));
  b.color_model = kBonnColorPca;
  const BonnColorTransform pca = BonnToRgb(b);
  EXPECT_TRUE(pca.to_rgb.isApprox(b.color_matrix.cast<double>().transpose()));
  EXPECT_TRUE(pca.offset.isApprox(b.color_mean.cast<double>()));
  b.color_model = 9;
  try {
    BonnToRgb(b);
    FAIL();
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("Ylog_UV"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mesocap::bonn
