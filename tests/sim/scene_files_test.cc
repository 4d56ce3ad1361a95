// Scenes read from files: an OBJ tile and a height map, and the files they
// refuse, each error naming the file.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "core/error.h"
#include "core/image_io.h"
#include "sim/builtin_scenes.h"
#include "sim/tiled_scene.h"
#include "tests/common/temporary_directory.h"
#include "tests/sim/scene_rays.h"

namespace mesocap::sim {
namespace {

using ::testing::HasSubstr;
using namespace scene_rays;

// ---------------------------------------------------------------- OBJ

void WriteText(const std::filesystem::path& file, const std::string& text) {
  std::ofstream(file, std::ios::binary) << text;
}

// A 1 x 1 x 0.3 cm box standing on a 1 x 1 cm base, placed off the origin
// and above z = 0 to exercise the shift; quads, a polygon, negative and
// v/vt/vn indices, comments and ignored statements.
constexpr const char* kBoxObj =
    "# test box\r\n"
    "mtllib none.mtl\n"
    "o base\n"
    "v 3 5 2\nv 4 5 2\nv 4 6 2\nv 3 6 2\n"
    "vt 0 0\nvn 0 0 1\n"
    "f 1/1/1 2/1/1 3/1/1 4/1/1\n"
    "o box\n"
    "v 3.25 5.25 2.3\nv 3.75 5.25 2.3\nv 3.75 5.75 2.3\nv 3.5 5.75 2.3\nv 3.25 5.75 2.3\n"
    "f -5 -4 -3 -2 -1\n"  // the top as a pentagon
    "v 3.25 5.25 2\nv 3.75 5.25 2\nv 3.75 5.75 2\nv 3.25 5.75 2\n"
    "f 10 11 6 5\nf 11 12 7 6\nf 12 13 9 7\nf 13 10 5 9\n"
    "s off\n";

TEST(ObjScene, LoadsAndShiftsTheTile) {
  testing::TemporaryDirectory dir;
  WriteText(dir / "box.obj", kBoxObj);
  const auto scene = LoadObjScene(dir / "box.obj", 10.0);  // cm to mm
  EXPECT_EQ(scene->name(), "box.obj");
  EXPECT_NEAR(scene->tile_size_mm(), 10.0, 1e-12);
  EXPECT_NEAR(scene->d_max_mm(), 3.0, 1e-12);
  EXPECT_NEAR(*Distance(*scene, Vec(5, 5, 1), Vec(0, 0, -1)), 1.0, 1e-12);    // box top at z = 0
  EXPECT_NEAR(*Distance(*scene, Vec(1, 1, 1), Vec(0, 0, -1)), 4.0, 1e-12);    // base at z = -3
  EXPECT_NEAR(*Distance(*scene, Vec(11, -9, 1), Vec(0, 0, -1)), 4.0, 1e-12);  // and its copies
  // A wall: from (1, 5) towards +x at 60 degrees meets x = 2.5 at z = -1.5 cot 60.
  EXPECT_NEAR(*Distance(*scene, Vec(1, 5, 0), -Omega(60, 180)), 1.5 / std::sin(60 * kDeg), 1e-9);
}

struct HostileObj {
  const char* name;
  const char* text;
  const char* expected;  // in the message besides the file name
};

class ObjRejects : public ::testing::TestWithParam<HostileObj> {};

TEST_P(ObjRejects, NamingTheFile) {
  testing::TemporaryDirectory dir;
  const auto file = dir / "bad.obj";
  WriteText(file, GetParam().text);
  try {
    LoadObjScene(file, 1.0);
    FAIL() << "accepted";
  } catch (const core::FormatError& e) {
    EXPECT_EQ(e.file(), file);
    EXPECT_THAT(e.what(), HasSubstr(file.string()));
    EXPECT_THAT(e.what(), HasSubstr(GetParam().expected));
  }
}

constexpr const char* kSquare = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

INSTANTIATE_TEST_SUITE_P(
    Hostile, ObjRejects,
    ::testing::Values(HostileObj{"Empty", "", "no faces"}, HostileObj{"OnlyVertices", kSquare, "no faces"},
                      HostileObj{"NanVertex", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n", "line 3"},
                      HostileObj{"InfVertex", "v 0 0 0\nv 1 0 inf\nv 1 1 0\nf 1 2 3\n", "line 2"},
                      HostileObj{"GarbageNumber", "v 0 0 0\nv 1 0x 0\n", "line 2"},
                      HostileObj{"ShortVertex", "v 0 0\n", "line 1"},
                      HostileObj{"IndexZero", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 0 1 2\n", "line 4"},
                      HostileObj{"IndexTooLarge", "v 0 0 0\nv 1 0 0\nv 1 1 0\n\nf 1 2 4\n", "line 5"},
                      HostileObj{"NegativeTooFar", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf -1 -2 -4\n", "line 4"},
                      HostileObj{"ForwardReference", "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 1 1 0\n", "line 3"},
                      HostileObj{"TwoVertexFace", "v 0 0 0\nv 1 0 0\nf 1 2\n", "line 3"},
                      HostileObj{"IndexNotANumber", "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 a\n", "line 4"},
                      HostileObj{"NotSquare", "v 0 0 0\nv 2 0 0\nv 2 1 0\nf 1 2 3\n", "extents"},
                      HostileObj{"NoExtent", "v 0 0 0\nv 0 0 1\nv 0 1 0\nf 1 2 3\n", "extent"},
                      HostileObj{"NoArea", "v 0 0 0\nv 1 1 0\nv 2 2 0\nf 1 2 3\n", "zero area"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(ObjScene, RejectsAMissingFileAndABadScale) {
  testing::TemporaryDirectory dir;
  EXPECT_THROW(LoadObjScene(dir / "missing.obj", 1.0), core::FormatError);
  EXPECT_THROW(LoadObjScene(dir.path(), 1.0), core::FormatError);
  WriteText(dir / "box.obj", kBoxObj);
  for (const double scale : {0.0, -1.0, std::nan("")}) {
    try {
      LoadObjScene(dir / "box.obj", scale);
      FAIL() << scale;
    } catch (const core::Error& e) {
      EXPECT_THAT(e.what(), HasSubstr("box.obj"));
    }
  }
}

// ---------------------------------------------------------------- height map

TEST(HeightMapScene, PixelCentresAreAtTheirHeights) {
  testing::TemporaryDirectory dir;
  core::Image image(4, 3, 1);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 4; ++x) image.at(x, y) = static_cast<float>((37 * (x + 4 * y) % 256) / 255.0);
  }
  image.at(2, 1) = 1.0f;
  core::WriteImage(dir / "h.png", image, core::PixelEncoding::kUInt8);
  const auto scene = LoadHeightMapScene(dir / "h.png", 4.0, 0.8);
  EXPECT_EQ(scene->tile_size_mm(), 4.0);
  EXPECT_EQ(scene->d_max_mm(), 0.8);
  for (int y = 0; y < 3; ++y) {
    for (int x = 0; x < 4; ++x) {
      const double expected = 1.0 + 0.8 * (1.0 - image.at(x, y));
      // Pixel (x, y) is at ((x + 0.5) P / w, (y + 0.5) P / h), and again one period over.
      for (const double shift : {0.0, 4.0, -8.0}) {
        const Vec top((x + 0.5) * 4.0 / 4 + shift, (y + 0.5) * 4.0 / 3 - shift, 1.0);
        EXPECT_NEAR(*Distance(*scene, top, Vec(0, 0, -1)), expected, 1e-6) << x << " " << y;
      }
    }
  }
  // Half-way between two pixel centres across the tile border: the mean height.
  const double between = 1.0 + 0.8 * (1.0 - 0.5 * (image.at(3, 0) + image.at(0, 0)));
  EXPECT_NEAR(*Distance(*scene, Vec(4.0, 0.5 * 4.0 / 3, 1.0), Vec(0, 0, -1)), between, 1e-6);
}

TEST(HeightMapScene, ColourImagesUseLuminance) {
  testing::TemporaryDirectory dir;
  core::Image image(2, 2, 3, 0.0f);
  image.at(0, 0, 0) = 1.0f;  // pure red: luminance 0.2126
  core::WriteImage(dir / "rgb.exr", image);
  const auto scene = LoadHeightMapScene(dir / "rgb.exr", 2.0, 1.0);
  EXPECT_NEAR(*Distance(*scene, Vec(0.5, 0.5, 0.0), Vec(0, 0, -1)), 1.0 - 0.2126, 1e-6);
  EXPECT_NEAR(*Distance(*scene, Vec(1.5, 1.5, 0.0), Vec(0, 0, -1)), 1.0, 1e-6);
}

TEST(HeightMapScene, RejectsHostileInputsNamingTheFile) {
  testing::TemporaryDirectory dir;
  const auto expect_rejected = [](const std::filesystem::path& file, double tile, double depth,
                                  const std::string& expected) {
    try {
      LoadHeightMapScene(file, tile, depth);
      FAIL() << "accepted " << file;
    } catch (const core::Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(file.string()));
      EXPECT_THAT(e.what(), HasSubstr(expected));
    }
  };
  core::Image too_high(3, 3, 1, 0.5f);
  too_high.at(1, 2) = 1.5f;
  core::WriteImage(dir / "high.exr", too_high);
  expect_rejected(dir / "high.exr", 4.0, 1.0, "pixel (1, 2)");
  core::Image not_a_number(3, 3, 1, 0.5f);
  not_a_number.at(2, 0) = std::nanf("");
  core::WriteImage(dir / "nan.exr", not_a_number);
  expect_rejected(dir / "nan.exr", 4.0, 1.0, "pixel (2, 0)");
  expect_rejected(dir / "missing.png", 4.0, 1.0, "not found");
  WriteText(dir / "text.png", "not an image");
  expect_rejected(dir / "text.png", 4.0, 1.0, "");
  core::WriteImage(dir / "big.png", core::Image(1100, 1000, 1, 0.5f), core::PixelEncoding::kUInt8);
  expect_rejected(dir / "big.png", 4.0, 1.0, "at most");
  core::WriteImage(dir / "ok.png", core::Image(2, 2, 1, 0.5f), core::PixelEncoding::kUInt8);
  expect_rejected(dir / "ok.png", 0.0, 1.0, "positive");
  expect_rejected(dir / "ok.png", 4.0, -1.0, "positive");
  expect_rejected(dir / "ok.png", std::nan(""), 1.0, "positive");
}

}  // namespace
}  // namespace mesocap::sim
