// Round trips of material packages through the Bonn forms against the
// simulated rig's exact BTF, within each form's quantization:
//   DFMF / FMF, float factors: float rounding of the products (1e-5 relative
//     to the sum of |terms|);
//   DFMF / FMF, half factors: each factor value within 2^-11 relative, so a
//     reconstructed value within (2 * 2^-11 + 2^-22) sum_k |u_k s_k| (plus
//     float rounding and the 2^-25 absolute error of subnormals);
//   UBO2003 8-bit sRGB: half the local code step; EXR half: 2^-11 relative.
// Plus the written headers against the checks of the Free BTF Library's
// loader (btf.hh), files in the other matrix orientation (what mesocap
// wrote before), counts that cannot tell the orientation, the cosine flag
// and the PCA mean against hand-made files. The package-level jobs (export
// and import) are tested in tests/pipelines/bonn_jobs_test.cc.
#include "interop/bonn/bonn_interop.h"

#include <OpenImageIO/color.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
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

// `file` written in float and read back: its row space is `rows`, and the
// BTF it holds (through mesocap's factors and, with `bonn_view`, through the
// database's own reconstruction) is `truth` to float rounding of its terms.
void ExpectFloatRoundTrip(const std::filesystem::path& path, const BonnBtfFile& file, BonnRowSpace rows,
                          const core::FullBtf& truth, bool bonn_view) {
  WriteBonnBtfFile(path, file, BonnScalar::kFloat);
  const BonnBtfFile read = ReadBonnBtfFile(path);
  EXPECT_EQ(read.row_space, rows) << path;
  const core::FactoredBtf back = FactoredFromBonn(read, path);
  auto bound = [&](int x, int y, int v, int l, int c) { return 1e-5 * TermSum(file, x, y, v, l, c) + 1e-6; };
  EXPECT_LE(WorstRatio(
                truth, [&](int v) { return btf::ReconstructBtfView(back, v); }, bound),
            1.0)
      << path;
  if (bonn_view) {
    EXPECT_LE(WorstRatio(
                  truth, [&](int v) { return BonnBtfView(read, v); }, bound),
              1.0)
        << path;
  }
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
    EXPECT_EQ(read.row_space, BonnRowSpace::kDirections);
    const core::FactoredBtf back = FactoredFromBonn(read, dir / "a.btf");
    EXPECT_EQ(back.layout, core::BtfFactorLayout::kPerTexel);
    EXPECT_EQ(back.rank(), 24);
    const double relative = scalar == BonnScalar::kHalf ? 2 * std::ldexp(1.0, -11) + std::ldexp(1.0, -22) : 0.0;
    const double ratio = WorstRatio(
        truth, [&](int v) { return btf::ReconstructBtfView(back, v); },
        [&](int x, int y, int v, int l, int c) { return (relative + 2e-6) * TermSum(written, x, y, v, l, c) + 1e-6; });
    EXPECT_LE(ratio, 1.0) << (scalar == BonnScalar::kHalf ? "half" : "float");
    // btflib's decode path (the full BTF) agrees with the factored import.
    const double decode = WorstRatio(
        truth, [&](int v) { return BonnBtfView(read, v); },
        [&](int x, int y, int v, int l, int c) { return (relative + 2e-6) * TermSum(written, x, y, v, l, c) + 1e-6; });
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
  const double ratio = WorstRatio(
      truth, [&](int v) { return btf::ReconstructBtfView(back, v); },
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
  o.rank = 24;  // full rank: min(3 x 48 directions, 24 texels)
  btf::BtfCompressionReport report;
  const BonnBtfFile written = BonnFmfFromFullBtf(truth, o, &report);
  EXPECT_EQ(report.rank, 24);
  EXPECT_LT(report.measured_relative_rms_error, 1e-5);
  ASSERT_EQ(written.factors.size(), 1u);
  EXPECT_EQ(written.row_space, BonnRowSpace::kDirections);
  EXPECT_EQ(written.factors[0].u.rows(), 3 * 48);
  EXPECT_EQ(written.factors[0].sxv.rows(), 24);
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
    EXPECT_LE(WorstRatio(
                  truth, [&](int v) { return btf::ReconstructBtfView(back, v); }, bound),
              1.0);
    EXPECT_LE(WorstRatio(
                  truth, [&](int v) { return BonnBtfView(read, v); }, bound),
              1.0);
  }
  // A lower rank: the error is the truncation the report states.
  o.rank = 0;
  o.max_relative_error = 0.05;
  const BonnBtfFile truncated = BonnFmfFromFullBtf(truth, o, &report);
  EXPECT_LT(report.rank, 24);
  EXPECT_LE(report.measured_relative_rms_error, 0.05);
  EXPECT_EQ(truncated.factors[0].rank(), report.rank);
}

// The same BTF in both orientations, with the light cosine multiplied in
// and a PCA mean: all decode to the same.
TEST(BonnInterop, CosineAndMeanAreUndoneInEitherOrientation) {
  const core::FullBtf& truth = TrueBtf();
  btf::BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.rank = 24;
  const BonnBtfFile base = BonnDfmfFromFactored(btf::CompressBtf(truth, o));
  const std::filesystem::path name = "test.btf";
  for (BonnRowSpace space : {BonnRowSpace::kDirections, BonnRowSpace::kTexels}) {
    BonnBtfFile file = base;
    if (space == BonnRowSpace::kTexels) {
      file.row_space = space;
      for (auto& f : file.factors) std::swap(f.u, f.sxv);
    }
    // Cosine flag: the file holds T cos(theta_l).
    file.cosine_flag = true;
    for (auto& f : file.factors) {
      BonnMatrix& directions = space == BonnRowSpace::kDirections ? f.u : f.sxv;
      for (int j = 0; j < directions.rows(); ++j)
        directions.row(j) *= std::cos(file.lights[j % file.light_count()].theta);
    }
    // PCA with identity matrix and mean m, decoded as btflib does, (f + m) /
    // cos(theta_l) = T: store f = T cos - m as the factors above plus one
    // component of -m.
    const Eigen::Vector3f mean(0.05f, -0.02f, 0.1f);
    file.color_model = kBonnColorPca;
    file.color_mean = mean;
    for (int c = 0; c < 3; ++c) {
      BonnFactors& f = file.factors[c];
      const int k = f.rank();
      f.u.conservativeResize(Eigen::NoChange, k + 1);
      f.sxv.conservativeResize(Eigen::NoChange, k + 1);
      f.singular_values.conservativeResize(k + 1);
      f.u.col(k).setConstant(-mean[c]);
      f.sxv.col(k).setOnes();
      f.singular_values[k] = 0.0f;
    }
    const core::FactoredBtf back = FactoredFromBonn(file, name);
    EXPECT_EQ(back.rank(), 26);  // 25 stored + the mean
    auto bound = [&](int x, int y, int v, int l, int c) { return 1e-5 * TermSum(base, x, y, v, l, c) + 2e-6; };
    EXPECT_LE(WorstRatio(
                  truth, [&](int v) { return btf::ReconstructBtfView(back, v); }, bound),
              1.0);
    EXPECT_LE(WorstRatio(
                  truth, [&](int v) { return BonnBtfView(file, v); }, bound),
              1.0);
  }

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

// Files in the orientation mesocap wrote before (U rows = texels), written
// to disk and imported: a DFMF with its factors swapped, and an FMF that
// holds the BTF itself, U(c + 3 texel, j) = T and SxV = identity.
TEST(BonnInterop, TexelRowFilesAreImported) {
  const core::FullBtf& truth = TrueBtf();
  testing::TemporaryDirectory dir;
  btf::BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.rank = 24;
  BonnBtfFile dfmf = BonnDfmfFromFactored(btf::CompressBtf(truth, o));
  dfmf.row_space = BonnRowSpace::kTexels;
  for (auto& f : dfmf.factors) std::swap(f.u, f.sxv);

  const int texels = truth.width * truth.height, directions = truth.view_count() * truth.light_count();
  BonnBtfFile fmf = dfmf;
  fmf.form = BonnBtfForm::kFmf;
  fmf.color_model = kBonnColorRgb;
  BonnFactors f;
  f.singular_values.setOnes(directions);
  f.u.resize(3 * texels, directions);
  f.sxv = BonnMatrix::Identity(directions, directions);
  for (int v = 0; v < truth.view_count(); ++v)
    for (int l = 0; l < truth.light_count(); ++l)
      for (int y = 0; y < truth.height; ++y)
        for (int x = 0; x < truth.width; ++x)
          for (int c = 0; c < 3; ++c)
            f.u(c + 3 * (x + truth.width * y), l + truth.light_count() * v) = truth.at(x, y, v, l)[c];
  fmf.factors = {f};

  for (const auto& [name, file] : {std::pair{"a.dfmf", dfmf}, std::pair{"a.fmf", fmf}}) {
    ExpectFloatRoundTrip(dir / name, file, BonnRowSpace::kTexels, truth, true);
  }
}

// The fields of a written file that the Free BTF Library's LoadBTF
// (github.com/zeroeffects/btf, btf.hh; what btf-extractor reads the
// database with) checks, read from the bytes here rather than through
// ReadBonnBtfFile.
struct FactorSizes {
  int scalar_size = 0;
  std::uint32_t components = 0, rows = 0, columns = 0;
};
struct WrittenHeader {
  std::uint32_t views = 0, lights = 0, width = 0, height = 0;
  int fmf_header_version = -1;
  std::vector<FactorSizes> factors;  // FMF one, DFMF one per channel
  std::size_t end = 0;               // offset after the last matrix
};

WrittenHeader ReadWrittenHeader(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  const std::string bytes{std::istreambuf_iterator<char>(in), {}};
  std::size_t at = 0;
  auto get = [&](auto value) {
    if (at + sizeof value > bytes.size()) throw core::Error("written header: past the end at " + std::to_string(at));
    std::memcpy(&value, bytes.data() + at, sizeof value);
    at += sizeof value;
    return value;
  };
  WrittenHeader h;
  const bool fmf = bytes.compare(0, 10, "!FMF12FCER") == 0;
  if (!fmf && bytes.compare(0, 10, "!DFMF08FCR") != 0) throw core::Error("written header: signature");
  at = 10;
  // btf.hh compares the meta block's declared size with what its fields take.
  const std::size_t meta_start = at;
  const auto meta_size = get(std::uint32_t{});
  EXPECT_EQ(get(std::uint32_t{}), 4u);  // version
  at += 3 * 80 + 4 + 12;
  get(std::uint32_t{});        // cosine flag
  at += get(std::uint32_t{});  // XML
  const auto channels = get(std::uint32_t{});
  EXPECT_EQ(channels, 3u);
  for (std::uint32_t c = 0; c < channels; ++c) at += get(std::uint32_t{});
  EXPECT_EQ(at - meta_start, meta_size);
  h.views = get(std::uint32_t{});
  for (std::uint32_t v = 0; v < h.views; ++v) {
    at += 8;
    const auto lights = get(std::uint32_t{});
    if (v == 0) h.lights = lights;
    EXPECT_EQ(lights, h.lights) << "view " << v;  // btf.hh refuses differing counts
    at += 8 * lights;
  }
  h.width = get(std::uint32_t{});
  h.height = get(std::uint32_t{});
  at += 36 * get(std::uint32_t{});  // rotations
  auto matrices = [&](int scalar, std::uint32_t k) {
    FactorSizes f;
    f.scalar_size = scalar;
    f.components = k;
    f.rows = get(std::uint32_t{});
    f.columns = get(std::uint32_t{});
    at += static_cast<std::size_t>(k) * (1 + f.rows + f.columns) * scalar;
    h.factors.push_back(f);
  };
  if (fmf) {
    h.fmf_header_version = get(std::uint8_t{});
    if (h.fmf_header_version >= 1) get(std::uint32_t{});  // dynamic-range reduction
    if (h.fmf_header_version >= 2) {
      const auto w = get(std::uint32_t{}), hh = get(std::uint32_t{});
      at += 2 * static_cast<std::size_t>(w) * hh;
    }
    const auto k = get(std::uint32_t{});
    const int scalar = get(std::uint8_t{});
    EXPECT_EQ(get(std::uint32_t{}), k);  // the count again
    matrices(scalar, k);
  } else {
    at += 4 + 4 + 12 + 36;  // largest K, colour model, mean, matrix
    for (std::uint32_t c = 0; c < channels; ++c) {
      const int scalar = get(std::uint8_t{});
      matrices(scalar, get(std::uint32_t{}));
    }
  }
  h.end = at;
  EXPECT_EQ(h.end, bytes.size()) << "btf.hh refuses bytes after the last matrix";
  return h;
}

TEST(BonnInterop, WrittenHeadersPassTheFreeBtfLibraryChecks) {
  testing::TemporaryDirectory dir;
  btf::BtfCompressionOptions per_texel;
  per_texel.layout = core::BtfFactorLayout::kPerTexel;
  per_texel.rank = 5;
  btf::BtfCompressionOptions fmf_options;
  fmf_options.rank = 5;
  // As many views as lights, as btf.hh requires (it squares the light
  // count; 8 x 6 texels): U's rows = Nlight^2, SxV's = W H.
  const core::SamplingSet grid = core::SamplingSet::Named("grid3x2");
  core::FullBtf square = core::MakeFullBtf(8, 6, grid, grid);
  for (int v = 0; v < square.view_count(); ++v)
    for (std::size_t i = 0; i < square.view_images[v].size(); ++i)
      square.view_images[v].data()[i] = 0.05f + 0.9f * static_cast<float>(((i * 13 + v * 7) % 97) / 97.0);
  for (const core::FullBtf* btf : {static_cast<const core::FullBtf*>(&square), &TrueBtf()}) {
    const std::uint32_t texels = btf->width * btf->height;
    const std::uint32_t directions = btf->view_count() * btf->light_count();
    WriteBonnBtfFile(dir / "a.dfmf", BonnDfmfFromFactored(btf::CompressBtf(*btf, per_texel)), BonnScalar::kHalf);
    WriteBonnBtfFile(dir / "a.fmf", BonnFmfFromFullBtf(*btf, fmf_options), BonnScalar::kHalf);
    const WrittenHeader d = ReadWrittenHeader(dir / "a.dfmf");
    EXPECT_EQ(d.views, static_cast<std::uint32_t>(btf->view_count()));
    EXPECT_EQ(d.lights, static_cast<std::uint32_t>(btf->light_count()));
    EXPECT_EQ(d.width * d.height, texels);
    ASSERT_EQ(d.factors.size(), 3u);
    for (const FactorSizes& f : d.factors) {
      EXPECT_EQ(f.scalar_size, 2);  // half, the same in every channel (btf.hh refuses a mix)
      EXPECT_EQ(f.components, 5u);
      EXPECT_EQ(f.rows, directions);  // the left factor: lights x views
      EXPECT_EQ(f.columns, texels);
      if (btf == &square) {
        EXPECT_EQ(f.rows, d.lights * d.lights);  // btf.hh's expected row count
      }
    }
    const WrittenHeader m = ReadWrittenHeader(dir / "a.fmf");
    EXPECT_LE(m.fmf_header_version, 2);  // btf.hh refuses 3 and above
    ASSERT_EQ(m.factors.size(), 1u);
    EXPECT_EQ(m.factors[0].scalar_size, 2);
    EXPECT_EQ(m.factors[0].components, 5u);
    EXPECT_EQ(m.factors[0].rows, 3 * directions);  // channels x lights x views
    EXPECT_EQ(m.factors[0].columns, texels);
    if (btf == &square) {
      EXPECT_EQ(m.factors[0].rows, 3 * m.lights * m.lights);
    }
  }
}

// Counts that cannot tell the orientation (8 x 6 texels = 8 views x 6
// lights): the exports write direction rows, the reader takes them so, and
// the BTF comes back.
TEST(BonnInterop, AmbiguousCountsRoundTrip) {
  core::FullBtf truth =
      core::MakeFullBtf(8, 6, core::SamplingSet::Named("grid4x2"), core::SamplingSet::Named("grid3x2"));
  ASSERT_EQ(truth.width * truth.height, truth.view_count() * truth.light_count());
  for (int v = 0; v < truth.view_count(); ++v)
    for (std::size_t i = 0; i < truth.view_images[v].size(); ++i)
      truth.view_images[v].data()[i] = 0.05f + 0.9f * static_cast<float>(((i * 11 + v * 29) % 89) / 89.0);
  testing::TemporaryDirectory dir;
  btf::BtfCompressionOptions o;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.rank = 48;  // full rank
  const BonnBtfFile dfmf = BonnDfmfFromFactored(btf::CompressBtf(truth, o));
  btf::BtfCompressionOptions fmf_options;
  fmf_options.rank = 48;
  const BonnBtfFile fmf = BonnFmfFromFullBtf(truth, fmf_options);
  for (const auto& [name, file] : {std::pair{"a.dfmf", dfmf}, std::pair{"a.fmf", fmf}}) {
    ExpectFloatRoundTrip(dir / name, file, BonnRowSpace::kDirections, truth, false);
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
