// The UBO2003 image form: file names, a round trip within the encodings'
// quantization (8-bit sRGB: half a code step; half float: 2^-11 relative),
// and bad folders: a missing image, an image of the wrong size, a name
// that does not parse, two images for one direction pair.
#include "interop/bonn/bonn_ubo2003.h"

#include <OpenImageIO/color.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/angles.h"
#include "core/error.h"
#include "interop/bonn/ubo_sampling_sets.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::bonn {
namespace {

constexpr double kDeg = core::kRadiansPerDegree;

core::SamplingSet Set(const std::vector<std::pair<double, double>>& degrees) {
  std::vector<core::SphericalAngles> a;
  for (const auto& [t, p] : degrees) a.push_back({t * kDeg, p * kDeg});
  return core::SamplingSet::FromAngles("test", a);
}

// Views and lights in ring order (the order a folder scan gives back); one
// light at a decimal angle.
const core::SamplingSet& Views() {
  static const core::SamplingSet s = Set({{0, 0}, {30, 0}, {30, 180}});
  return s;
}
const core::SamplingSet& Lights() {
  static const core::SamplingSet s = Set({{0, 0}, {15, 300}, {45, 90}, {67.5, 270}});
  return s;
}

// Distinct values in (0, 1) for every x, y, view, light and channel, on a
// 5 x 3 grid (not square, so a swapped x and y shows).
constexpr int kW = 5, kH = 3;
core::Image ViewImage(int v) {
  const int nl = Lights().size();
  core::Image img(kW, kH * nl, 3);
  for (int l = 0; l < nl; ++l)
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x)
        for (int c = 0; c < 3; ++c)
          img.at(x, l * kH + y, c) =
              0.02f + 0.9f * static_cast<float>(((x * 7 + y * 5 + v * 11 + l * 3 + c * 13) % 97) / 97.0);
  return img;
}

void WriteAll(const std::filesystem::path& dir, Ubo2003Encoding encoding, double scale) {
  for (int v = 0; v < Views().size(); ++v) {
    EXPECT_EQ(WriteUbo2003View(dir, Views(), Lights(), v, ViewImage(v), encoding, scale), 0);
  }
}

TEST(Ubo2003Names, BonnNaming) {
  EXPECT_EQ(Ubo2003ImageName({15 * kDeg, 60 * kDeg}, {30 * kDeg, 90 * kDeg}, Ubo2003Encoding::kSrgb8Png),
            "tl015_pl060_tv030_pv090.png");
  EXPECT_EQ(Ubo2003ImageName({0, 0}, {75 * kDeg, 345 * kDeg}, Ubo2003Encoding::kHalfExr),
            "tl000_pl000_tv075_pv345.exr");
  EXPECT_EQ(Ubo2003ImageName({5.625 * kDeg, 0}, {0, 0}, Ubo2003Encoding::kSrgb8Png), "tl005.625_pl000_tv000_pv000.png");
}

TEST(Ubo2003Images, Srgb8RoundTripIsWithinHalfACodeStep) {
  testing::TemporaryDirectory dir;
  WriteAll(dir.path(), Ubo2003Encoding::kSrgb8Png, 1.0);
  const Ubo2003ImageSet set = ScanUbo2003Folder(dir.path());
  ASSERT_EQ(set.width, kW);
  ASSERT_EQ(set.height, kH);
  ASSERT_EQ(set.views.size(), Views().size());
  ASSERT_EQ(set.lights.size(), Lights().size());
  for (int l = 0; l < Lights().size(); ++l) {
    EXPECT_NEAR(set.lights.angles(l).theta, Lights().angles(l).theta, 1e-12);
    EXPECT_NEAR(set.lights.angles(l).phi, Lights().angles(l).phi, 1e-12);
  }
  for (int v = 0; v < Views().size(); ++v) {
    const core::Image got = ReadUbo2003View(set, v, 1.0);
    const core::Image want = ViewImage(v);
    for (std::size_t i = 0; i < want.size(); ++i) {
      // The code nearest to the sRGB encoding of the value, decoded: the
      // error is at most half the linear step between neighbouring codes.
      const float w = want.data()[i];
      const float code = std::round(OIIO::linear_to_sRGB(w) * 255.0f);
      const float step = OIIO::sRGB_to_linear(std::min(code + 1, 255.0f) / 255.0f) -
                         OIIO::sRGB_to_linear(std::max(code - 1, 0.0f) / 255.0f);
      EXPECT_LE(std::abs(got.data()[i] - w), 0.5f * step + 1e-6f) << v << " " << i;
    }
  }
}

TEST(Ubo2003Images, HalfExrRoundTripIsWithinHalfRoundingAndScaled) {
  testing::TemporaryDirectory dir;
  WriteAll(dir.path(), Ubo2003Encoding::kHalfExr, 100.0);
  const Ubo2003ImageSet set = ScanUbo2003Folder(dir.path());
  for (int v = 0; v < Views().size(); ++v) {
    const core::Image got = ReadUbo2003View(set, v, 100.0);
    const core::Image want = ViewImage(v);
    for (std::size_t i = 0; i < want.size(); ++i) {
      EXPECT_LE(std::abs(got.data()[i] - want.data()[i]), std::ldexp(1.0f, -11) * want.data()[i] * 1.0001f) << i;
    }
  }
}

TEST(Ubo2003Images, EightBitClipsAndCounts) {
  testing::TemporaryDirectory dir;
  core::Image img = ViewImage(0);
  img.at(1, 1, 0) = 1.5f;
  img.at(2, 2, 1) = -0.1f;
  EXPECT_EQ(WriteUbo2003View(dir.path(), Views(), Lights(), 0, img, Ubo2003Encoding::kSrgb8Png, 1.0), 2);
}

void ExpectScanError(const std::filesystem::path& dir, const std::string& file_part, const std::string& words) {
  try {
    ScanUbo2003Folder(dir);
    FAIL() << "no error";
  } catch (const core::Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(file_part), std::string::npos) << what;
    EXPECT_NE(what.find(words), std::string::npos) << what;
  }
}

TEST(Ubo2003Images, BadFoldersNameTheFile) {
  testing::TemporaryDirectory dir;
  WriteAll(dir.path(), Ubo2003Encoding::kSrgb8Png, 1.0);
  const std::string victim = "tl045_pl090_tv030_pv180.png";
  ASSERT_TRUE(std::filesystem::exists(dir / victim));

  std::filesystem::rename(dir / victim, dir / "keep.bin");
  ExpectScanError(dir.path(), victim, "missing");
  std::filesystem::rename(dir / "keep.bin", dir / victim);

  core::WriteImage(dir / victim, core::Image(kW + 1, kH, 3, 0.5f), core::PixelEncoding::kUInt8);
  ExpectScanError(dir.path(), victim, "field 'width'");
  core::WriteImage(dir / victim, core::Image(kW, kH, 1, 0.5f), core::PixelEncoding::kUInt8);
  ExpectScanError(dir.path(), victim, "channels");
  core::WriteImage(dir / victim, core::Image(kW, kH, 3, 0.5f), core::PixelEncoding::kUInt8);
  EXPECT_NO_THROW(ScanUbo2003Folder(dir.path()));

  core::WriteImage(dir / "tl015_plxx_tv000_pv000.png", core::Image(kW, kH, 3), core::PixelEncoding::kUInt8);
  ExpectScanError(dir.path(), "tl015_plxx_tv000_pv000.png", "expected tl<deg>_pl<deg>_tv<deg>_pv<deg>");
  std::filesystem::remove(dir / "tl015_plxx_tv000_pv000.png");

  core::WriteImage(dir / "tl095_pl000_tv000_pv000.png", core::Image(kW, kH, 3), core::PixelEncoding::kUInt8);
  ExpectScanError(dir.path(), "tl095_pl000_tv000_pv000.png", "upper hemisphere");
  std::filesystem::remove(dir / "tl095_pl000_tv000_pv000.png");

  // The same pair again, in a view subfolder and with the tokens reordered.
  std::filesystem::create_directories(dir / "tv030_pv180");
  core::WriteImage(dir / "tv030_pv180" / "tv30_pv180_tl45_pl90.png", core::Image(kW, kH, 3),
                   core::PixelEncoding::kUInt8);
  ExpectScanError(dir.path(), "tv30_pv180_tl45_pl90.png", "the same light and view directions");
  std::filesystem::remove_all(dir / "tv030_pv180");

  testing::TemporaryDirectory empty;
  ExpectScanError(empty.path(), empty.path().string(), "no Bonn BTF images");
}

TEST(Ubo2003Images, NamedSetIsRecognised) {
  // The 81 UBO2003 views under one light scan to the named set.
  testing::TemporaryDirectory dir;
  const core::SamplingSet ubo = NamedSamplingSet("ubo2003");
  const core::SamplingSet one_light = Set({{0, 0}});
  for (int v = 0; v < ubo.size(); ++v) {
    WriteUbo2003View(dir.path(), ubo, one_light, v, core::Image(2, 2, 3, 0.25f), Ubo2003Encoding::kSrgb8Png, 1.0);
  }
  const Ubo2003ImageSet set = ScanUbo2003Folder(dir.path());
  EXPECT_EQ(set.views.name(), "ubo2003");
  EXPECT_EQ(set.lights.name(), "bonn_images");
  EXPECT_EQ(set.lights.size(), 1);
}

}  // namespace
}  // namespace mesocap::bonn
