// `mesocap render`, `compare` and `view` as a user runs them: a scene with a
// factored material package renders headless; bad scenes and materials and a
// missing display give one clear line and exit 1.
#include <gtest/gtest.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/image_io.h"
#include "formats/material_manifest.h"
#include "formats/material_package_writer.h"
#include "render/image_comparison.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/temporary_directory.h"
#include "tests/render/lambertian_material.h"

namespace mesocap::render {
namespace {

using testing::Mesocap;

// A package with the parts the renderer reads (the blocks geometry, a
// rank-1 Lambertian BTF).
void WritePackage(const std::filesystem::path& package) {
  const render::RenderMaterial m = LambertianSimMaterial("blocks", 16);
  formats::MaterialDescription d;
  d.name = "blocks-lambertian";
  d.width = d.height = 16;
  d.physical_size_mm = {m.sample_size_mm, m.sample_size_mm};
  d.d_max_mm = m.d_max_mm;
  d.view_directions = m.mdf.views;
  d.light_directions = m.btf.lights;
  formats::MaterialPackageWriter writer(package, d, false);
  writer.WriteMdf(m.mdf);
  writer.WriteFactoredBtf(m.btf);
  writer.WriteAmbientTerm(m.ambient);
  writer.Commit();
}

// That package as dir/blocks, and a scene naming `material`.
void WriteScene(const std::filesystem::path& dir, const std::string& material) {
  WritePackage(dir / "blocks");
  std::ofstream(dir / "scene.json") << R"({"format": "mesocap.scene", "version": 1,
    "camera": {"position": [0, -120, 75], "look_at": [0, 0, -4]},
    "light": {"position": [80, -60, 170], "intensity": 60000},
    "objects": [{"shape": "torus", "major_radius": 26, "minor_radius": 10, "tiles": [8, 3],
                 "material": ")" + material +
                                           R"("}]})";
}

TEST(RenderCli, RendersAFactoredPackageHeadless) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "blocks");
  const auto out = dir / "torus.png";
  const testing::CommandResult r =
      Mesocap("render " + (dir / "scene.json").string() + " --size 64x48 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const core::Image image = core::ReadImage(out);
  EXPECT_EQ(image.width(), 64);
  EXPECT_EQ(image.height(), 48);
  // The torus covers the middle of the frame, lit from above: not black.
  EXPECT_GT(image.at(32, 14, 0), 0.02f);
}

TEST(RenderCli, MissingMaterialNamesTheManifest) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "no-such-package");
  const testing::CommandResult r =
      Mesocap("render " + (dir / "scene.json").string() + " --out " + (dir / "x.png").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no-such-package"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
}

TEST(RenderCli, MalformedSceneNamesTheField) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "bad.json") << R"({"format": "mesocap.scene", "version": 1,
    "camera": {"position": [0, -1, 0], "look_at": [0, 0, 0]}, "light": {"position": [0, 0, 9], "intensity": 1},
    "objects": [{"shape": "torus", "major_radius": 5, "minor_radius": 9}]})";
  const testing::CommandResult r =
      Mesocap("render " + (dir / "bad.json").string() + " --out " + (dir / "x.png").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("objects[0].minor_radius"), std::string::npos) << r.err;
}

TEST(RenderCli, CompareNeedsTrueGeometry) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "blocks");
  const testing::CommandResult r = Mesocap("compare " + (dir / "scene.json").string() + " --size 32x24");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no true geometry"), std::string::npos) << r.err;
}

// `compare --json` reports the issue's names per mode; `--images` writes the
// masks and their differences, whose coloured pixels are exactly where the
// rendered and reference masks disagree.
TEST(RenderCli, CompareReportsEveryModeAndWritesTheDifferences) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "sim:blocks");
  // A cached sim: material, so the test does not build one from ground truth.
  WritePackage(dir / "cache" / "materials" / "blocks-v3");
  const testing::CommandResult r = Mesocap("compare " + (dir / "scene.json").string() +
                                               " --size 48x36 --repeat 1 --json --images " + (dir / "images").string(),
                                           "MESOCAP_CACHE_DIR=" + (dir / "cache").string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  for (const char* mode : {"btf", "silhouette", "full"}) {
    SCOPED_TRACE(mode);
    const nlohmann::json& m = report.at(mode);
    for (const char* name : {"coverage_iou", "shadow_iou"}) {
      EXPECT_GE(m.at(name).get<double>(), 0.5);
      EXPECT_LE(m.at(name).get<double>(), 1.0);
    }
    EXPECT_GT(m.at("psnr_db").get<double>(), 10.0);
    EXPECT_GT(m.at("frame_ms").get<double>(), 0.0);
    EXPECT_GE(m.at("passes").get<int>(), 1);
    const core::Image shadow = core::ReadImage(dir / "images" / (std::string(mode) + "_shadow.png"));
    const core::Image truth = core::ReadImage(dir / "images" / "reference_shadow.png");
    const core::Image difference = core::ReadImage(dir / "images" / (std::string(mode) + "_shadow_difference.png"));
    long disagree = 0, marked = 0, either = 0;
    for (int y = 0; y < truth.height(); ++y) {
      for (int x = 0; x < truth.width(); ++x) {
        const bool a = shadow.at(x, y) > 0.5f, b = truth.at(x, y) > 0.5f;
        disagree += a != b;
        either += a || b;
        marked += difference.at(x, y, 0) > 0.9f || difference.at(x, y, 1) > 0.9f;
      }
    }
    EXPECT_EQ(marked, disagree);
    EXPECT_NEAR(m.at("shadow_iou").get<double>(), either == 0 ? 1.0 : 1.0 - double(disagree) / double(either), 1e-9);
  }
}

TEST(RenderCli, ViewWithoutADisplaySaysSo) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "blocks");
  const testing::CommandResult r =
      Mesocap("view " + (dir / "scene.json").string(), "env -u DISPLAY -u WAYLAND_DISPLAY");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no display"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace mesocap::render
