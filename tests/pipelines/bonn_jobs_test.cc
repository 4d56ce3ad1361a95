// The Bonn export and import jobs on material packages: a round trip of the
// simulated rig's exact BTF through every form, within each form's
// quantization (tests/bonn/bonn_interop_test.cc tells the bounds), and
// failures leaving nothing behind.
#include <OpenImageIO/color.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "btf/ambient_term.h"
#include "btf/btf_compression.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "pipelines/export_bonn.h"
#include "pipelines/import_bonn.h"
#include "tests/bonn/bonn_round_trip.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::pipelines {
namespace {

using bonn::BonnBtfFile;
using bonn::BonnForm;
using bonn::BonnScalar;
using bonn::ReadBonnBtfFile;
using bonn::Ubo2003Encoding;
using testing::PackageOf;
using testing::TermSum;
using testing::TrueBtf;
using testing::WorstRatio;

// The jobs with their paths given as the tests give them.
ExportBonnReport ExportBonn(const std::filesystem::path& in, const std::filesystem::path& out,
                            ExportBonnOptions options) {
  options.in = in;
  options.out = out;
  return RunExportBonn(options);
}

ImportBonnReport ImportBonn(const std::filesystem::path& in, const std::filesystem::path& out,
                            ImportBonnOptions options) {
  options.in = in;
  options.out = out;
  return RunImportBonn(options);
}

TEST(BonnJobs, PackageRoundTripsThroughEveryForm) {
  testing::TemporaryDirectory dir;
  const core::FullBtf& truth = TrueBtf();
  formats::WriteMaterialPackage(dir / "in", PackageOf(truth), false);

  ImportBonnOptions import;
  import.d_max_mm = 1.5;
  import.flat_mdf = true;

  // UBO2003, 8-bit sRGB: within half a code step (the values are below 1).
  ExportBonnOptions png;
  png.form = BonnForm::kUbo2003;
  const ExportBonnReport r = ExportBonn(dir / "in", dir / "ubo", png);
  EXPECT_EQ(r.files, 8 * 6);
  EXPECT_EQ(r.clipped_values, 0);
  import.width_mm = 12.0;
  const ImportBonnReport ir = ImportBonn(dir / "ubo", dir / "from_ubo", import);
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
  const double srgb = WorstRatio(
      truth, [&](int v) { return from_ubo.view_images[v]; },
      [&](int x, int y, int v, int l, int c) {
        const float w = truth.at(x, y, v, l)[c];
        const float code = std::round(OIIO::linear_to_sRGB(w) * 255.0f);
        return 0.5 * (OIIO::sRGB_to_linear(std::min(code + 1, 255.0f) / 255.0f) -
                      OIIO::sRGB_to_linear(std::max(code - 1, 0.0f) / 255.0f)) +
               1e-6;
      });
  EXPECT_LE(srgb, 1.0);

  // DFMF from a full BTF (factored here at full rank), half, imported factored.
  ExportBonnOptions dfmf;
  dfmf.form = BonnForm::kDfmf;
  dfmf.compression.rank = 24;
  const ExportBonnReport dr = ExportBonn(dir / "in", dir / "a.dfmf", dfmf);
  EXPECT_EQ(dr.rank, 24);
  import.width_mm = 0.0;  // from the file's pixels per mm
  const ImportBonnReport di = ImportBonn(dir / "a.dfmf", dir / "from_dfmf", import);
  EXPECT_EQ(di.rank, 24);
  EXPECT_NEAR(di.manifest.description.physical_size_mm.x(), 12.0, 1e-5);
  const core::FactoredBtf from_dfmf = formats::ReadFactoredBtf(dir / "from_dfmf", di.manifest);
  const BonnBtfFile dfile = ReadBonnBtfFile(dir / "a.dfmf");
  EXPECT_LE(WorstRatio(
                truth, [&](int v) { return btf::ReconstructBtfView(from_dfmf, v); },
                [&](int x, int y, int v, int l, int c) {
                  return (2.1 * std::ldexp(1.0, -11) + 2e-6) * TermSum(dfile, x, y, v, l, c) + 1e-6;
                }),
            1.0);
  // The ambient term is the truth's (btf/ambient_term.h) within the
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
  ExportBonnOptions fmf;
  fmf.form = BonnForm::kFmf;
  fmf.scalar = BonnScalar::kFloat;
  fmf.compression.rank = 24;  // full rank: min(3 x 48 directions, 24 texels)
  ExportBonn(dir / "in", dir / "a.fmf", fmf);
  import.parts = BonnImportParts::kBoth;
  const ImportBonnReport fi = ImportBonn(dir / "a.fmf", dir / "from_fmf", import);
  EXPECT_TRUE(fi.manifest.full_btf);
  EXPECT_EQ(fi.rank, 24);
  const core::FullBtf from_fmf = formats::ReadFullBtf(dir / "from_fmf", fi.manifest);
  const BonnBtfFile ffile = ReadBonnBtfFile(dir / "a.fmf");
  EXPECT_LE(WorstRatio(
                truth, [&](int v) { return from_fmf.view_images[v]; },
                [&](int x, int y, int v, int l, int c) { return 1e-5 * TermSum(ffile, x, y, v, l, c) + 1e-6; }),
            1.0);
}

TEST(BonnJobs, FailuresLeaveNothingBehind) {
  testing::TemporaryDirectory dir;
  core::FullBtf big = TrueBtf();
  big.view_images[2].at(1, 1, 0) = 1e6f;  // does not fit a half
  formats::WriteMaterialPackage(dir / "in", PackageOf(big), false);

  ExportBonnOptions exr;
  exr.form = BonnForm::kUbo2003;
  exr.encoding = Ubo2003Encoding::kHalfExr;
  EXPECT_THROW(ExportBonn(dir / "in", dir / "ubo", exr), core::Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "ubo"));

  ExportBonnOptions dfmf;
  dfmf.form = BonnForm::kDfmf;
  dfmf.compression.rank = 24;
  EXPECT_THROW(ExportBonn(dir / "in", dir / "a.dfmf", dfmf), core::Error);
  EXPECT_FALSE(std::filesystem::exists(dir / "a.dfmf"));

  // An existing target is kept unless --replace.
  std::filesystem::create_directories(dir / "taken");
  ExportBonnOptions png;
  png.form = BonnForm::kUbo2003;
  EXPECT_THROW(ExportBonn(dir / "in", dir / "taken", png), core::Error);
  dfmf.scalar = BonnScalar::kFloat;
  ExportBonn(dir / "in", dir / "a.dfmf", dfmf);
  EXPECT_THROW(ExportBonn(dir / "in", dir / "a.dfmf", dfmf), core::Error);

  // Import of a truncated file: FormatError, no package.
  std::filesystem::resize_file(dir / "a.dfmf", std::filesystem::file_size(dir / "a.dfmf") - 7);
  ImportBonnOptions import;
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
}  // namespace mesocap::pipelines
