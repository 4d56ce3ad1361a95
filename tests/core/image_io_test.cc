#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/image_io.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::core {
namespace {

Image Gradient(int w, int h, int c) {
  Image img(w, h, c);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int k = 0; k < c; ++k) img.at(x, y, k) = (x + 2.0f * y + 0.25f * k) / (w + 2.0f * h + 1.0f);
  return img;
}

float MaxAbsDiff(const Image& a, const Image& b) {
  float m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a.data()[i] - b.data()[i]));
  return m;
}

TEST(Image, RejectsBadSizes) {
  EXPECT_THROW(Image(0, 4, 1), Error);
  EXPECT_THROW(Image(4, -1, 1), Error);
  EXPECT_THROW(Image(4, 4, 5), Error);
  EXPECT_THROW(Image(4, 4, 0), Error);
}

// Each container/encoding pair round-trips within its quantization step.
struct Case {
  const char* ext;
  PixelEncoding encoding;
  float tolerance;
};

std::string CaseName(const ::testing::TestParamInfo<std::tuple<Case, int>>& info) {
  const Case& c = std::get<0>(info.param);
  return std::string(c.ext + 1) + "_" + ToString(c.encoding) + "_" + std::to_string(std::get<1>(info.param)) + "ch";
}

class ImageRoundTrip : public ::testing::TestWithParam<std::tuple<Case, int>> {};

TEST_P(ImageRoundTrip, ValuesSurviveWithinQuantization) {
  const auto [c, channels] = GetParam();
  testing::TemporaryDirectory dir;
  const auto file = dir / (std::string("img") + c.ext);
  const Image img = Gradient(37, 23, channels);
  WriteImage(file, img, c.encoding);
  const Image back = ReadImage(file);
  ASSERT_EQ(back.width(), 37);
  ASSERT_EQ(back.height(), 23);
  ASSERT_EQ(back.channels(), channels);
  EXPECT_LE(MaxAbsDiff(img, back), c.tolerance);
  EXPECT_EQ(ReadImageHeader(file).encoding, c.encoding);
}

INSTANTIATE_TEST_SUITE_P(
    AllFormats, ImageRoundTrip,
    ::testing::Combine(::testing::Values(Case{".exr", PixelEncoding::kFloat32, 0.0f},
                                         Case{".exr", PixelEncoding::kHalf, 1e-3f},
                                         Case{".png", PixelEncoding::kUInt8, 0.5f / 255 + 1e-6f},
                                         Case{".png", PixelEncoding::kUInt16, 0.5f / 65535 + 1e-7f},
                                         Case{".tif", PixelEncoding::kFloat32, 0.0f},
                                         Case{".tiff", PixelEncoding::kUInt16, 0.5f / 65535 + 1e-7f}),
                       ::testing::Values(1, 3, 4)),
    CaseName);
// JPEG holds grey or colour, 8 bits, lossy (colour subsampled): within 5 codes.
INSTANTIATE_TEST_SUITE_P(Jpeg, ImageRoundTrip,
                         ::testing::Combine(::testing::Values(Case{".jpg", PixelEncoding::kUInt8, 5.0f / 255},
                                                              Case{".jpeg", PixelEncoding::kUInt8, 5.0f / 255}),
                                            ::testing::Values(1, 3)),
                         CaseName);

TEST(ImageIo, FloatExrKeepsInfinityAndNan) {
  // The MDF's "no hit" (+inf) and "unknown" (NaN) codes must survive storage.
  testing::TemporaryDirectory dir;
  Image img(2, 1, 1);
  img.at(0, 0) = std::numeric_limits<float>::infinity();
  img.at(1, 0) = std::numeric_limits<float>::quiet_NaN();
  WriteImage(dir / "special.exr", img);
  const Image back = ReadImage(dir / "special.exr");
  EXPECT_TRUE(std::isinf(back.at(0, 0)) && back.at(0, 0) > 0);
  EXPECT_TRUE(std::isnan(back.at(1, 0)));
}

TEST(ImageIo, RejectsEncodingTheContainerCannotHold) {
  testing::TemporaryDirectory dir;
  EXPECT_THROW(WriteImage(dir / "a.png", Gradient(4, 4, 1), PixelEncoding::kFloat32), Error);
  EXPECT_THROW(WriteImage(dir / "a.exr", Gradient(4, 4, 1), PixelEncoding::kUInt8), Error);
  EXPECT_THROW(WriteImage(dir / "a.bmp", Gradient(4, 4, 1)), Error);
  EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << "a refused write left a file behind";
}

TEST(ImageIo, MissingFileNamesTheFile) {
  testing::TemporaryDirectory dir;
  try {
    ReadImage(dir / "nope.exr");
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("nope.exr"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos);
  }
}

TEST(ImageIo, TruncatedFilesAreErrorsNotCrashes) {
  testing::TemporaryDirectory dir;
  for (const char* ext : {".exr", ".png", ".tif"}) {
    const auto file = dir / (std::string("t") + ext);
    WriteImage(file, Gradient(64, 64, 3), std::string(ext) == ".png" ? PixelEncoding::kUInt8 : PixelEncoding::kFloat32);
    const auto size = std::filesystem::file_size(file);
    for (double keep : {0.0, 0.1, 0.5, 0.9}) {
      std::filesystem::resize_file(file, static_cast<std::uintmax_t>(size * keep));
      EXPECT_THROW(ReadImage(file), FormatError) << ext << " truncated to " << keep;
      WriteImage(file, Gradient(64, 64, 3),
                 std::string(ext) == ".png" ? PixelEncoding::kUInt8 : PixelEncoding::kFloat32);
    }
  }
}

TEST(ImageIo, RowReaderReadsAnyRangeAsTheWholeImageHasIt) {
  testing::TemporaryDirectory dir;
  const Image image = Gradient(24, 70, 3);  // EXR zip blocks of 16 lines: ranges straddle them
  WriteImage(dir / "r.exr", image);
  ImageReadOptions expected;
  expected.expected_width = 24;
  expected.expected_channels = 3;
  ImageRowReader reader(dir / "r.exr", expected);
  EXPECT_EQ(reader.header().height, 70);
  // Out of order, overlapping, straddling blocks, the last line.
  for (const auto& [first, rows] : {std::pair{30, 20}, std::pair{0, 7}, std::pair{69, 1}, std::pair{5, 40}}) {
    std::vector<float> out(3 * 24 * rows);
    reader.Read(first, rows, out.data());
    for (int i = 0; i < 3 * 24 * rows; ++i) ASSERT_EQ(out[i], image.pixel(0, first)[i]) << first << "+" << rows;
  }
  std::vector<float> out(3 * 24 * 2);
  EXPECT_THROW(reader.Read(69, 2, out.data()), FormatError);
  EXPECT_THROW(reader.Read(-1, 1, out.data()), FormatError);
  expected.expected_height = 71;
  EXPECT_THROW(ImageRowReader(dir / "r.exr", expected), FormatError);
  // Truncated after opening is checked: the read fails, naming the file.
  std::filesystem::resize_file(dir / "r.exr", std::filesystem::file_size(dir / "r.exr") / 2);
  try {
    ImageRowReader truncated(dir / "r.exr", {});
    std::vector<float> all(3 * 24 * 70);
    truncated.Read(0, 70, all.data());
    FAIL() << "expected an error";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("r.exr"), std::string::npos) << e.what();
  }
}

TEST(ImageIo, GarbageIsRejected) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "g.exr") << "this is not an image at all";
  EXPECT_THROW(ReadImage(dir / "g.exr"), FormatError);
}

TEST(ImageIo, ExpectationsAndLimitsAreCheckedBeforeAllocation) {
  testing::TemporaryDirectory dir;
  WriteImage(dir / "a.exr", Gradient(16, 8, 3));
  ImageReadOptions o;
  o.expected_width = 17;
  try {
    ReadImage(dir / "a.exr", o);
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_EQ(e.field(), "width");
  }
  o = {};
  o.expected_channels = 1;
  EXPECT_THROW(ReadImage(dir / "a.exr", o), FormatError);
  o = {};
  o.max_values = 16 * 8 * 3 - 1;
  try {
    ReadImage(dir / "a.exr", o);
    FAIL();
  } catch (const FormatError& e) {
    EXPECT_EQ(e.field(), "size");
  }
}

TEST(ImageIo, OverwriteIsAtomicAndKeepsOldFileOnFailure) {
  testing::TemporaryDirectory dir;
  WriteImage(dir / "a.exr", Gradient(8, 8, 1));
  EXPECT_THROW(WriteImage(dir / "a.exr", Image{}), Error);  // empty image refused
  EXPECT_EQ(ReadImage(dir / "a.exr").width(), 8);
  int files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1) << "temporary files left behind";
}

// A JPEG written by the image library itself, with the attributes a camera
// sets (progressive coding, EXIF orientation).
void WriteJpeg(const std::filesystem::path& file, const Image& image, int orientation, bool progressive) {
  auto out = OIIO::ImageOutput::create(file.string());
  ASSERT_TRUE(out);
  OIIO::ImageSpec spec(image.width(), image.height(), image.channels(), OIIO::TypeDesc::UINT8);
  spec.attribute("Orientation", orientation);
  spec.attribute("jpeg:progressive", progressive ? 1 : 0);
  spec.attribute("Compression", "jpeg:100");
  ASSERT_TRUE(out->open(file.string(), spec));
  ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, image.data()));
  ASSERT_TRUE(out->close());
}

TEST(ImageIo, ProgressiveJpegIsRead) {
  testing::TemporaryDirectory dir;
  const Image img = Gradient(40, 24, 3);
  WriteJpeg(dir / "p.jpeg", img, 1, true);
  const Image back = ReadImage(dir / "p.jpeg");
  ASSERT_EQ(back.width(), 40);
  ASSERT_EQ(back.height(), 24);
  EXPECT_LE(MaxAbsDiff(img, back), 5.0f / 255);
}

// A photo taken with the camera on its side: stored 4 x 2, tagged "turn 90
// degrees clockwise to display" (EXIF 6). It reads back upright, 2 x 4, the
// stored top-left pixel at the top right.
TEST(ImageIo, ExifOrientationIsHonoured) {
  testing::TemporaryDirectory dir;
  Image stored(4, 2, 1, 0.0f);
  stored.at(0, 0) = 1.0f;
  WriteJpeg(dir / "turned.jpg", stored, 6, false);
  const ImageHeader header = ReadImageHeader(dir / "turned.jpg");
  EXPECT_EQ(header.width, 2);
  EXPECT_EQ(header.height, 4);
  const Image upright = ReadImage(dir / "turned.jpg");
  ASSERT_EQ(upright.width(), 2);
  ASSERT_EQ(upright.height(), 4);
  EXPECT_GT(upright.at(1, 0), 0.5f);
  EXPECT_LT(upright.at(0, 0), 0.5f);
  EXPECT_LT(upright.at(1, 3), 0.5f);
  // Reading by rows would see the stored rows: refused, naming the field.
  try {
    ImageRowReader rows(dir / "turned.jpg", {});
    FAIL() << "a turned image was read by rows";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("Orientation"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mesocap::core
