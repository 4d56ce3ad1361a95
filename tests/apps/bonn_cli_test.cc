// `mesocap export bonn` and `mesocap import bonn` run as a user would: a
// package round trip through a DFMF file (float factors) and through a
// UBO2003 image folder (8-bit sRGB), and bad input (a truncated file, a
// wrong signature, a missing flag) failing with one line naming the file
// and field, a non-zero exit and no output.
#include <OpenImageIO/color.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <string>

#include "formats/material_manifest.h"
#include "formats/material_package.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "interop/bonn/bonn_btf_file.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

using testing::CommandResult;
using testing::Mesocap;

// A 6 x 4 BTF (not square) on 8 views x 6 lights with distinct values in (0, 1).
formats::MaterialPackage SyntheticPackage() {
  formats::MaterialPackage p;
  formats::MaterialDescription& d = p.description;
  d.name = "synthetic";
  d.width = 6;
  d.height = 4;
  d.physical_size_mm = {12.0, 8.0};
  d.d_max_mm = 1.0;
  d.view_directions = core::SamplingSet::Named("grid4x2");
  d.light_directions = core::SamplingSet::Named("grid3x2");
  core::FullBtf btf = core::MakeFullBtf(d.width, d.height, d.view_directions, d.light_directions);
  for (int v = 0; v < btf.view_count(); ++v)
    for (std::size_t i = 0; i < btf.view_images[v].size(); ++i)
      btf.view_images[v].data()[i] = 0.02f + 0.9f * static_cast<float>(((i * 7 + v * 31) % 101) / 101.0);
  p.full_btf = btf;
  return p;
}

float MaxAbsDifference(const core::FullBtf& a, const core::FullBtf& b) {
  float worst = 0.0f;
  for (int v = 0; v < a.view_count(); ++v)
    for (std::size_t i = 0; i < a.view_images[v].size(); ++i)
      worst = std::max(worst, std::abs(a.view_images[v].data()[i] - b.view_images[v].data()[i]));
  return worst;
}

TEST(BonnCli, RoundTripsThroughDfmfAndImages) {
  testing::TemporaryDirectory dir;
  const formats::MaterialPackage package = SyntheticPackage();
  formats::WriteMaterialPackage(dir / "in", package, false);
  const std::string in = (dir / "in").string();

  CommandResult r = Mesocap("export bonn --in " + in + " --out " + (dir / "a.btf").string() +
                            " --form dfmf --rank 24 --scalar float");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // The database's orientation: U's rows are the 8 x 6 direction pairs.
  const bonn::BonnBtfFile written = bonn::ReadBonnBtfFile(dir / "a.btf");
  EXPECT_EQ(written.row_space, bonn::BonnRowSpace::kDirections);
  EXPECT_EQ(written.factors[0].u.rows(), 48);
  r = Mesocap("import bonn --in " + (dir / "a.btf").string() + " --out " + (dir / "back").string() +
              " --d-max-mm 1 --btf both");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const formats::MaterialManifest back = formats::ReadMaterialManifest(dir / "back");
  EXPECT_TRUE(back.full_btf);
  ASSERT_TRUE(back.factored_btf.has_value());
  EXPECT_EQ(back.factored_btf->rank, 24);
  EXPECT_TRUE(back.ambient);
  EXPECT_NEAR(back.description.physical_size_mm.x(), 12.0, 1e-5);  // from the file's pixels per mm
  // Full rank, float factors: the values up to float rounding of 24-term sums.
  EXPECT_LT(MaxAbsDifference(*package.full_btf, formats::ReadFullBtf(dir / "back", back)), 1e-5f);

  r = Mesocap("export bonn --in " + in + " --out " + (dir / "images").string() + " --form ubo2003");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(std::filesystem::exists(dir / "images" / "tl022.5_pl000_tv067.5_pv090.png"));
  r = Mesocap("import bonn --in " + (dir / "images").string() + " --out " + (dir / "from_images").string() +
              " --d-max-mm 1 --size-mm 12 --flat-mdf");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const formats::MaterialManifest images = formats::ReadMaterialManifest(dir / "from_images");
  EXPECT_TRUE(images.mdf.has_value());
  // 8-bit sRGB: within half the largest linear step between two codes.
  const float half_step = 0.5f * (1.0f - OIIO::sRGB_to_linear(254.0f / 255.0f));
  EXPECT_LE(MaxAbsDifference(*package.full_btf, formats::ReadFullBtf(dir / "from_images", images)), half_step + 1e-6f);
}

TEST(BonnCli, BadInputFailsWithOneLineAndNoOutput) {
  testing::TemporaryDirectory dir;
  formats::WriteMaterialPackage(dir / "in", SyntheticPackage(), false);
  CommandResult r = Mesocap("export bonn --in " + (dir / "in").string() + " --out " + (dir / "a.btf").string() +
                            " --form fmf --rank 10");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(bonn::ReadBonnBtfFile(dir / "a.btf").factors[0].u.rows(), 3 * 48);
  std::filesystem::resize_file(dir / "a.btf", std::filesystem::file_size(dir / "a.btf") / 2);
  r = Mesocap("import bonn --in " + (dir / "a.btf").string() + " --out " + (dir / "out").string() + " --d-max-mm 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find((dir / "a.btf").string()), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("truncated"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));

  std::ofstream(dir / "b.btf") << "!BDIF06R2! not a factored BTF";
  r = Mesocap("import bonn --in " + (dir / "b.btf").string() + " --out " + (dir / "out").string() + " --d-max-mm 1");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("field 'signature'"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "out"));

  r = Mesocap("import bonn --in " + (dir / "a.btf").string() + " --out " + (dir / "out").string());
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("--d-max-mm"), std::string::npos) << r.err;
  r = Mesocap("export bonn --in " + (dir / "in").string() + " --out " + (dir / "x").string() + " --form bdi");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_FALSE(std::filesystem::exists(dir / "x"));
}

}  // namespace
}  // namespace mesocap
