// Shapes and tangent frames (Wang et al. 2005 Sec. 5: per-vertex texture
// scale and frame) against their analytic values.
#include "render/render_mesh.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <numbers>
#include <string>

#include "core/error.h"
#include "render/render_scene.h"
#include "tests/common/error_of.h"
#include "tests/common/temporary_directory.h"
#include "tests/render/lambertian_material.h"

namespace mesocap::render {
namespace {

constexpr double kPi = std::numbers::pi;

TEST(RenderMesh, CylinderFramesFollowTheTextureAndScaleIsArcLengthPerSample) {
  // r 20, 8 x 3 tiles over circumference x height 40, sample 10 mm:
  // s_u = 2 pi 20 / 8 / 10, s_v = 40 / 3 / 10, s = sqrt(s_u s_v).
  RenderMesh mesh = MakeCylinder(20, 40, 256, 8, {8, 3});
  ComputeTangentFrames(&mesh, 10.0);
  const double expected = std::sqrt(2 * kPi * 20 / 8 / 10 * (40.0 / 3 / 10));
  const int side_vertices = 257 * 9;
  for (int i = 0; i < side_vertices; i += 37) {
    const Eigen::Vector3f p = mesh.positions[i];
    const Eigen::Vector3f radial = Eigen::Vector3f(p.x(), p.y(), 0).normalized();
    EXPECT_NEAR(mesh.normals[i].dot(radial), 1.0, 1e-5) << i;
    // +u runs counter-clockwise about +z: tangent = z x radial.
    EXPECT_NEAR(mesh.tangents[i].head<3>().dot(Eigen::Vector3f::UnitZ().cross(radial)), 1.0, 1e-3) << i;
    // +v runs up: bitangent = w n x t = +z.
    EXPECT_NEAR((mesh.tangents[i].w() * mesh.normals[i].cross(mesh.tangents[i].head<3>())).z(), 1.0, 1e-3) << i;
    EXPECT_NEAR(mesh.texture_scale[i], expected, 1e-3 * expected) << i;
  }
}

TEST(RenderMesh, TorusAndKnotNormalsPointOutOfTheTube) {
  const RenderMesh torus = MakeTorus(26, 10, 64, 32, {8, 3});
  for (int i = 0; i < torus.vertex_count(); ++i) {
    const Eigen::Vector3f p = torus.positions[i];
    const Eigen::Vector3f centre = Eigen::Vector3f(p.x(), p.y(), 0).normalized() * 26;
    EXPECT_NEAR(torus.normals[i].dot((p - centre).normalized()), 1.0, 1e-4) << i;
  }
  // Every triangle winds counter-clockwise seen from outside: its face normal
  // agrees with the vertex normals.
  const RenderMesh knot = MakeTorusKnot(30, 6, 2, 3, 256, 24, {48, 8});
  for (const Eigen::Vector3i& t : knot.triangles) {
    const Eigen::Vector3f face =
        (knot.positions[t[1]] - knot.positions[t[0]]).cross(knot.positions[t[2]] - knot.positions[t[0]]);
    EXPECT_GT(face.dot(knot.normals[t[0]]), 0.0f);
  }
}

TEST(RenderMesh, BoxIsClosedAndOutwardFacing) {
  const RenderMesh box = MakeBox({-1, -2, -3}, {1, 2, 3}, 10);
  ASSERT_EQ(box.triangles.size(), 12u);
  // Divergence theorem: the signed volume of an outward closed mesh is its volume.
  double volume = 0;
  for (const Eigen::Vector3i& t : box.triangles) {
    volume += box.positions[t[0]].cast<double>().dot(
                  box.positions[t[1]].cast<double>().cross(box.positions[t[2]].cast<double>())) /
              6.0;
  }
  EXPECT_NEAR(volume, 2.0 * 4.0 * 6.0, 1e-9);
}

TEST(RenderMesh, DegenerateTextureCoordinatesGiveNoMesostructure) {
  RenderMesh mesh;
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  mesh.normals.assign(3, Eigen::Vector3f::UnitZ());
  mesh.texcoords = {{0, 0}, {1, 1}, {2, 2}};  // collinear
  mesh.triangles = {{0, 1, 2}};
  ComputeTangentFrames(&mesh, 1.0);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(mesh.texture_scale[i], 0.0f);
    EXPECT_NEAR(mesh.tangents[i].head<3>().dot(mesh.normals[i]), 0.0, 1e-6);
  }
}

}  // namespace
}  // namespace mesocap::render

namespace mesocap::render {
namespace {

TEST(RenderMesh, ObjWithTextureCoordinatesAndDerivedNormals) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "quad.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                     "f 1/1 2/2 3/3 4/4\n";
  RenderMesh mesh = LoadObjRenderMesh(dir / "quad.obj", 10.0, {2, 3});
  ASSERT_EQ(mesh.vertex_count(), 4);
  ASSERT_EQ(mesh.triangles.size(), 2u);
  EXPECT_NEAR(mesh.positions[2].x(), 10.0f, 1e-6);
  EXPECT_NEAR(mesh.texcoords[2].y(), 3.0f, 1e-6);
  EXPECT_NEAR(mesh.normals[0].z(), 1.0f, 1e-6);
  // 10 mm per 1/2 texture unit: s = 5 mm per material mm for a 1 mm sample.
  ComputeTangentFrames(&mesh, 1.0);
  EXPECT_NEAR(mesh.texture_scale[0], std::sqrt(5.0 * 10.0 / 3.0), 1e-4);
}

TEST(RenderMesh, ObjWithoutTextureCoordinatesNamesTheFile) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "bare.obj") << "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n";
  const std::string error = testing::ErrorOf<core::FormatError>([&] {
    LoadObjRenderMesh(dir / "bare.obj", 1.0, {1, 1});
  });
  EXPECT_NE(error.find("bare.obj"), std::string::npos) << error;
  EXPECT_NE(error.find("texture coordinate"), std::string::npos) << error;
}

// A vertex of 1e308 (or any coordinate beyond 1e6) is refused with the
// range, not drawn black.
TEST(RenderMesh, ObjCoordinatesOutsideTheRangeAreRefused) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "far.obj") << "v 0 0 0\nv 1e308 0 0\nv 1 1 0\nvt 0 0\nf 1/1 2/1 3/1\n";
  EXPECT_EQ(testing::ErrorOf<core::FormatError>([&] {
              LoadObjRenderMesh(dir / "far.obj", 1.0, {1, 1});
            }),
            (dir / "far.obj").string() + ": field 'line 2': vertex coordinate 1e308 is outside [-1e+06, 1e+06]");
}

// Writes a one-box scene with `light` as its light member and returns the
// error reading it gives ("" when it reads).
std::string SceneError(const std::filesystem::path& dir, const std::string& light, const std::string& extra = "") {
  std::ofstream(dir / "scene.json") << R"({"format": "mesocap.scene", "version": 1,
    "camera": {"position": [0, -100, 0], "look_at": [0, 0, 0]}, "light": )"
                                    << light << R"(, "objects": [{"shape": "box", "min": [-10, -10, -10],
    "max": [10, 10, 10])" << extra << "}]}";
  try {
    ReadRenderScene(dir / "scene.json", [](const std::string&, const std::filesystem::path&) -> RenderMaterial {
      throw core::Error("no materials here");
    });
  } catch (const core::Error& e) {
    return e.what();
  }
  return "";
}

// docs/FORMATS.md "Render scene": the light lies outside the scene's
// bounding sphere (here centre 0, radius sqrt(300) = 17.3 mm).
TEST(RenderScene, ALightInsideTheBoundingSphereIsRefused) {
  testing::TemporaryDirectory dir;
  EXPECT_EQ(SceneError(dir.path(), R"({"position": [0, 0, 18], "intensity": 1})"), "");
  const std::string inside = SceneError(dir.path(), R"({"position": [0, 0, 17], "intensity": 1})");
  EXPECT_NE(inside.find("scene.json: field 'light.position': expected a point outside the scene's bounding sphere "
                        "(centre [0, 0, 0], radius 17.3205 mm), got one 17 mm from its centre"),
            std::string::npos)
      << inside;
}

TEST(RenderScene, HugeStringsAndAbsurdNumbersAreRefusedReadably) {
  testing::TemporaryDirectory dir;
  const std::string huge(500000, 'q');  // under the scene's 1 MiB
  const std::string shape = SceneError(dir.path(), R"({"position": [0, 0, 50], "intensity": 1})",
                                       R"(, "tiles_per_100mm": 1, ")" + huge + R"(": 1)");
  EXPECT_LT(shape.size(), 1000u);
  EXPECT_NE(shape.find("field 'objects[0]." + std::string(60, 'q') + "... (500000 bytes in all)': unknown member"),
            std::string::npos)
      << shape.substr(0, 400);
  const std::string far = SceneError(dir.path(), R"({"position": [0, 0, 1e300], "intensity": 1})");
  EXPECT_NE(far.find("field 'light.position[2]': expected a finite number in [-1e+06, 1e+06], got number 1e+300"),
            std::string::npos)
      << far;
}

// Every shipped scene reads, names built-in sim: materials, and carries
// mesostructure on its textured object (the scenes README and FORMATS.md list).
TEST(RenderScene, EveryShippedSceneReads) {
  int scenes = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(std::filesystem::path(MESOCAP_SOURCE_DIR) / "render/scenes")) {
    SCOPED_TRACE(entry.path().string());
    std::vector<std::string> specs;
    const RenderScene scene = ReadRenderScene(entry.path(), [&](const std::string& spec, const std::filesystem::path&) {
      specs.push_back(spec);
      EXPECT_EQ(spec.rfind("sim:", 0), 0u);
      return LambertianSimMaterial(spec.substr(4), 8);
    });
    EXPECT_EQ(specs.size(), 1u);
    EXPECT_EQ(scene.materials.size(), 1u);
    int textured = 0;
    for (const SceneObject& object : scene.objects) textured += object.material >= 0;
    EXPECT_EQ(textured, 1);
    ++scenes;
  }
  EXPECT_EQ(scenes, 7);
}

}  // namespace
}  // namespace mesocap::render
