#include "formats/frame_sequence.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/image_io.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::formats {
namespace {

namespace fs = std::filesystem;

core::Image Frame(int w, int h, int c, int index) {
  core::Image image(w, h, c);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int k = 0; k < c; ++k)
        image.at(x, y, k) = static_cast<float>(((x + 3 * y + 7 * k + 11 * index) % 97) / 96.0);
    }
  }
  return image;
}

TEST(FrameSequenceTest, RoundTripsFramesOneByOneWithinHalfACode) {
  testing::TemporaryDirectory dir;
  const fs::path file = dir / "sweep.tif";
  constexpr int kFrames = 5;
  {
    FrameSequenceWriter writer(file, 13, 7, 1);
    for (int f = 0; f < kFrames; ++f) writer.Append(Frame(13, 7, 1, f));
    EXPECT_FALSE(fs::exists(file)) << "visible before Commit";
    writer.Commit();
  }
  FrameSequenceReader reader(file);
  EXPECT_EQ(reader.header().width, 13);
  EXPECT_EQ(reader.header().height, 7);
  EXPECT_EQ(reader.header().channels, 1);
  EXPECT_EQ(reader.header().encoding, core::PixelEncoding::kUInt16);
  EXPECT_EQ(reader.header().frame_count, kFrames);
  core::Image frame;
  int f = 0;
  while (reader.Next(&frame)) {
    const core::Image expected = Frame(13, 7, 1, f);
    for (std::size_t i = 0; i < expected.size(); ++i) {
      ASSERT_NEAR(frame.data()[i], expected.data()[i], 0.5 / 65535 + 1e-7) << "frame " << f << " value " << i;
    }
    ++f;
  }
  EXPECT_EQ(f, kFrames);
  EXPECT_EQ(ReadFrameSequenceHeader(file).frame_count, kFrames);
  // An ordinary TIFF reader sees frame 0.
  EXPECT_NEAR(core::ReadImage(file).at(4, 2), Frame(13, 7, 1, 0).at(4, 2), 1e-4);
}

TEST(FrameSequenceTest, FloatFramesAreExact) {
  testing::TemporaryDirectory dir;
  const fs::path file = dir / "sweep.tiff";
  {
    FrameSequenceWriter writer(file, 4, 3, 3, core::PixelEncoding::kFloat32);
    for (int f = 0; f < 3; ++f) writer.Append(Frame(4, 3, 3, f));
    writer.Commit();
  }
  FrameSequenceReader reader(file);
  EXPECT_EQ(reader.header().encoding, core::PixelEncoding::kFloat32);
  core::Image frame;
  for (int f = 0; f < 3; ++f) {
    ASSERT_TRUE(reader.Next(&frame));
    EXPECT_EQ(frame.at(3, 2, 2), Frame(4, 3, 3, f).at(3, 2, 2));
  }
  EXPECT_FALSE(reader.Next(&frame));
}

TEST(FrameSequenceTest, WithoutCommitLeavesNothing) {
  testing::TemporaryDirectory dir;
  {
    FrameSequenceWriter writer(dir / "sweep.tif", 4, 4, 1);
    writer.Append(Frame(4, 4, 1, 0));
  }
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(FrameSequenceTest, RejectsMismatchedFramesAndEmptySequences) {
  testing::TemporaryDirectory dir;
  FrameSequenceWriter writer(dir / "sweep.tif", 4, 4, 1);
  EXPECT_THROW(writer.Append(Frame(4, 5, 1, 0)), core::Error);
  EXPECT_THROW(writer.Append(Frame(4, 4, 2, 0)), core::Error);
  EXPECT_THROW(writer.Commit(), core::Error);
  EXPECT_THROW(FrameSequenceWriter(dir / "sweep.png", 4, 4, 1), core::Error);
  EXPECT_THROW(FrameSequenceWriter(dir / "sweep.tif", 4, 4, 1, core::PixelEncoding::kHalf), core::Error);
}

TEST(FrameSequenceTest, ReaderNamesTheFileAndTheField) {
  testing::TemporaryDirectory dir;
  EXPECT_THROW(FrameSequenceReader(dir / "missing.tif"), core::FormatError);
  const fs::path garbage = dir / "garbage.tif";
  core::WriteTextFileAtomically(garbage, "not a tiff");
  try {
    FrameSequenceReader reader(garbage);
    FAIL() << "accepted garbage";
  } catch (const core::FormatError& e) {
    EXPECT_EQ(e.file(), garbage);
  }
  const fs::path many = dir / "many.tif";
  {
    FrameSequenceWriter writer(many, 4, 4, 1);
    for (int f = 0; f < 4; ++f) writer.Append(Frame(4, 4, 1, f));
    writer.Commit();
  }
  try {
    FrameSequenceReader reader(many, 3);
    FAIL() << "accepted more frames than the limit";
  } catch (const core::FormatError& e) {
    EXPECT_EQ(e.field(), "frames");
  }
  EXPECT_THROW(FrameSequenceReader(many, 10, 15), core::FormatError);
}

}  // namespace
}  // namespace mesocap::formats
