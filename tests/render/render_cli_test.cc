// `mesocap render`, `compare` and `view` as a user runs them: a scene with a
// factored material package renders headless; bad scenes and materials and a
// missing display give one clear line and exit 1.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <fstream>
#include <string>

#include "core/image_io.h"
#include "core/material_package.h"
#include "tests/common/temporary_directory.h"
#include "tests/render/lambertian_material.h"

namespace mesocap::render {
namespace {

struct CommandResult {
  int exit_code = -1;
  std::string err;
};

CommandResult Mesocap(const std::string& args, const std::string& env = "") {
  testing::TemporaryDirectory dir;
  const std::string cmd =
      env + " " + std::string(MESOCAP_BINARY) + " " + args + " >/dev/null 2>" + (dir / "err").string();
  const int status = std::system(cmd.c_str());
  std::ifstream in(dir / "err");
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, {std::istreambuf_iterator<char>(in), {}}};
}

// A package with the parts the renderer reads, and a scene using it.
void WriteScene(const std::filesystem::path& dir, const std::string& material) {
  const RenderMaterial m = LambertianSimMaterial("blocks", 16);
  MaterialDescription d;
  d.name = "blocks-lambertian";
  d.width = d.height = 16;
  d.physical_size_mm = {m.sample_size_mm, m.sample_size_mm};
  d.d_max_mm = m.d_max_mm;
  d.view_directions = m.mdf.views;
  d.light_directions = m.btf.lights;
  MaterialPackageWriter writer(dir / "blocks", d, false);
  writer.WriteMdf(m.mdf);
  writer.WriteFactoredBtf(m.btf);
  writer.WriteAmbientTerm(m.ambient);
  writer.Commit();
  std::ofstream(dir / "scene.json") << R"({"format": "mesocap.scene", "version": 1,
    "camera": {"position": [0, -120, 75], "look_at": [0, 0, -4]},
    "light": {"position": [80, -60, 170], "intensity": 60000},
    "objects": [{"shape": "torus", "major_radius": 26, "minor_radius": 10, "tiles": [8, 3],
                 "material": ")" + material + R"("}]})";
}

TEST(RenderCli, RendersAFactoredPackageHeadless) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "blocks");
  const auto out = dir / "torus.png";
  const CommandResult r = Mesocap("render " + (dir / "scene.json").string() + " --size 64x48 --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const Image image = ReadImage(out);
  EXPECT_EQ(image.width(), 64);
  EXPECT_EQ(image.height(), 48);
  // The torus covers the middle of the frame, lit from above: not black.
  EXPECT_GT(image.at(32, 14, 0), 0.02f);
}

TEST(RenderCli, MissingMaterialNamesTheManifest) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "no-such-package");
  const CommandResult r = Mesocap("render " + (dir / "scene.json").string() + " --out " + (dir / "x.png").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no-such-package"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "x.png"));
}

TEST(RenderCli, MalformedSceneNamesTheField) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "bad.json") << R"({"format": "mesocap.scene", "version": 1,
    "camera": {"position": [0, -1, 0], "look_at": [0, 0, 0]}, "light": {"position": [0, 0, 9], "intensity": 1},
    "objects": [{"shape": "torus", "major_radius": 5, "minor_radius": 9}]})";
  const CommandResult r = Mesocap("render " + (dir / "bad.json").string() + " --out " + (dir / "x.png").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("objects[0].minor_radius"), std::string::npos) << r.err;
}

TEST(RenderCli, CompareNeedsTrueGeometry) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "blocks");
  const CommandResult r = Mesocap("compare " + (dir / "scene.json").string() + " --size 32x24");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no true geometry"), std::string::npos) << r.err;
}

TEST(RenderCli, ViewWithoutADisplaySaysSo) {
  testing::TemporaryDirectory dir;
  WriteScene(dir.path(), "blocks");
  const CommandResult r = Mesocap("view " + (dir / "scene.json").string(), "env -u DISPLAY -u WAYLAND_DISPLAY");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("no display"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace mesocap::render
