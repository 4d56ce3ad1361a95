#include "render/render_scene.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>

#include "core/angles.h"
#include "core/error.h"
#include "core/json_field_reader.h"

namespace mesocap::render {
namespace {

// Positions and extents in a scene (mm): far beyond any scene, near enough
// that float vertices keep sub-millimetre steps.
constexpr double kMaxCoordinateMm = 1e6;

Eigen::Vector3f Albedo(const core::JsonFieldReader& o, std::string_view key) {
  return (o.Has(key) ? o.Vector3(key, 0.0, 1.0) : Eigen::Vector3d::Constant(0.5)).cast<float>();
}

Eigen::Vector2d Tiles(const core::JsonFieldReader& o) {
  const Eigen::Vector2d tiles = o.Has("tiles") ? o.Vector2("tiles") : Eigen::Vector2d(1, 1);
  if (!(tiles.minCoeff() > 0) || tiles.maxCoeff() > 1000) o.Fail("tiles", "expected two numbers in (0, 1000]");
  return tiles;
}

int Segments(const core::JsonFieldReader& o, std::string_view key, int fallback) {
  return o.Has(key) ? static_cast<int>(o.Integer(key, 3, 4096)) : fallback;
}

RenderMesh ReadShape(const core::JsonFieldReader& o, const std::filesystem::path& scene_dir) {
  const std::string shape = o.Choice("shape", {"cylinder", "torus", "torus_knot", "box", "obj"});
  if (shape == "obj") {
    o.RejectUnknownMembers(
        {"name", "shape", "file", "scale", "tiles", "material", "albedo", "translate", "rotate_deg"});
    const std::filesystem::path file(o.String("file"));
    return LoadObjRenderMesh(file.is_absolute() ? file : scene_dir / file, o.NumberOr("scale", 1.0, 1e-9, 1e9),
                             Tiles(o));
  }
  if (shape == "cylinder") {
    o.RejectUnknownMembers({"name", "shape", "radius", "height", "segments", "rings", "tiles", "material", "albedo",
                            "cap_albedo", "translate", "rotate_deg"});
    const double radius = o.Number("radius", 1e-3, 1e5), height = o.Number("height", 1e-3, 1e5);
    const int segments = Segments(o, "segments", 96);
    // With cap_albedo the caps become a plain object of their own (ReadRenderScene).
    return o.Has("cap_albedo") ? MakeCylinderSide(radius, height, segments, Segments(o, "rings", 8), Tiles(o))
                               : MakeCylinder(radius, height, segments, Segments(o, "rings", 8), Tiles(o));
  }
  if (shape == "torus") {
    o.RejectUnknownMembers({"name", "shape", "major_radius", "minor_radius", "segments", "tube_segments", "tiles",
                            "material", "albedo", "translate", "rotate_deg"});
    const double major = o.Number("major_radius", 1e-3, 1e5);
    const double minor = o.Number("minor_radius", 1e-3, 1e5);
    if (minor >= major) o.Fail("minor_radius", "expected less than major_radius (a ring torus)");
    return MakeTorus(major, minor, Segments(o, "segments", 96), Segments(o, "tube_segments", 48), Tiles(o));
  }
  if (shape == "torus_knot") {
    o.RejectUnknownMembers({"name", "shape", "radius", "tube_radius", "p", "q", "segments", "tube_segments", "tiles",
                            "material", "albedo", "translate", "rotate_deg"});
    return MakeTorusKnot(o.Number("radius", 1e-3, 1e5), o.Number("tube_radius", 1e-3, 1e5),
                         static_cast<int>(o.Integer("p", 1, 16)), static_cast<int>(o.Integer("q", 1, 16)),
                         Segments(o, "segments", 256), Segments(o, "tube_segments", 32), Tiles(o));
  }
  o.RejectUnknownMembers(
      {"name", "shape", "min", "max", "tiles_per_100mm", "material", "albedo", "translate", "rotate_deg"});
  const Eigen::Vector3d min = o.Vector3("min", -kMaxCoordinateMm, kMaxCoordinateMm);
  const Eigen::Vector3d max = o.Vector3("max", -kMaxCoordinateMm, kMaxCoordinateMm);
  if (!((max - min).minCoeff() > 0)) o.Fail("max", "expected every coordinate above min's");
  return MakeBox(min, max, o.NumberOr("tiles_per_100mm", 1.0, 1e-3, 1e4));
}

}  // namespace

std::pair<Eigen::Vector3d, double> RenderScene::Bounds() const {
  Eigen::AlignedBox3d box;
  for (const SceneObject& object : objects) {
    for (const Eigen::Vector3f& p : object.mesh.positions) box.extend(p.cast<double>());
  }
  if (box.isEmpty()) return {Eigen::Vector3d::Zero(), 1.0};
  return {box.center(), std::max(0.5 * box.diagonal().norm(), 1e-6)};
}

RenderMaterial ResolvePackageMaterial(const std::string& spec, const std::filesystem::path& scene_dir) {
  const std::filesystem::path path(spec);
  return LoadRenderMaterial(path.is_absolute() ? path : scene_dir / path);
}

RenderScene ReadRenderScene(const std::filesystem::path& file, const MaterialResolver& resolver) {
  const nlohmann::json document = core::ReadJsonFile(file, 1 << 20);
  const core::JsonFieldReader root(document, file);
  root.ExpectFormat("mesocap.scene", 1);
  root.RejectUnknownMembers({"format", "version", "camera", "light", "exposure", "objects"});
  RenderScene scene;
  scene.file = file;
  {
    const core::JsonFieldReader c = root.Object("camera");
    c.RejectUnknownMembers({"position", "look_at", "up", "fov_y_deg"});
    scene.camera.position = c.Vector3("position", -kMaxCoordinateMm, kMaxCoordinateMm);
    scene.camera.look_at = c.Vector3("look_at", -kMaxCoordinateMm, kMaxCoordinateMm);
    scene.camera.up = c.Has("up") ? c.Vector3("up", -kMaxCoordinateMm, kMaxCoordinateMm) : Eigen::Vector3d(0, 0, 1);
    scene.camera.fov_y_deg = c.NumberOr("fov_y_deg", 40.0, 1.0, 170.0);
    const Eigen::Vector3d forward = scene.camera.look_at - scene.camera.position;
    if (forward.norm() <= 0) c.Fail("look_at", "expected a point other than the camera position");
    if (forward.normalized().cross(scene.camera.up.normalized()).norm() < 1e-6) {
      c.Fail("up", "expected a direction not parallel to the viewing direction");
    }
  }
  {
    const core::JsonFieldReader l = root.Object("light");
    l.RejectUnknownMembers({"position", "intensity", "ambient"});
    scene.light.position = l.Vector3("position", -kMaxCoordinateMm, kMaxCoordinateMm);
    scene.light.intensity = l.Number("intensity", 0.0, 1e12);
    scene.light.ambient = l.NumberOr("ambient", 0.1, 0.0, 1e6);
  }
  scene.exposure = root.NumberOr("exposure", 1.0, 1e-12, 1e12);
  const std::filesystem::path scene_dir = file.parent_path();
  std::vector<std::string> material_specs;
  for (const core::JsonFieldReader& o : root.Objects("objects", 64)) {
    SceneObject object;
    object.name = o.StringOr("name", "object");
    object.mesh = ReadShape(o, scene_dir);
    double sample_size_mm = 1.0;
    if (o.Has("material")) {
      if (o.Has("albedo")) o.Fail("albedo", "an object has either a material or an albedo, not both");
      const std::string spec = o.String("material");
      const auto known = std::find(material_specs.begin(), material_specs.end(), spec);
      object.material = static_cast<int>(known - material_specs.begin());
      if (known == material_specs.end()) {
        try {
          scene.materials.push_back(resolver(spec, scene_dir));
        } catch (const core::Error& e) {
          o.Fail("material", std::string("cannot use this material: ") + e.what());
        }
        material_specs.push_back(spec);
      }
      sample_size_mm = scene.materials[object.material].sample_size_mm;
    } else {
      object.albedo = Albedo(o, "albedo");
    }
    std::vector<SceneObject> parts;
    if (o.Has("cap_albedo")) {
      SceneObject caps;
      caps.name = object.name + " caps";
      caps.mesh = MakeCylinderCaps(o.Number("radius"), o.Number("height"), Segments(o, "segments", 96), Tiles(o));
      caps.albedo = Albedo(o, "cap_albedo");
      ComputeTangentFrames(&caps.mesh, 1.0);
      parts.push_back(std::move(caps));
    }
    ComputeTangentFrames(&object.mesh, sample_size_mm);
    parts.insert(parts.begin(), std::move(object));
    const Eigen::Vector3d r = o.Has("rotate_deg")
                                  ? Eigen::Vector3d(o.Vector3("rotate_deg", -360.0, 360.0) * core::kRadiansPerDegree)
                                  : Eigen::Vector3d::Zero();
    const Eigen::Matrix3d rotation =
        (Eigen::AngleAxisd(r.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r.y(), Eigen::Vector3d::UnitY()) *
         Eigen::AngleAxisd(r.x(), Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
    const Eigen::Vector3d translation =
        o.Has("translate") ? o.Vector3("translate", -kMaxCoordinateMm, kMaxCoordinateMm) : Eigen::Vector3d::Zero();
    for (SceneObject& part : parts) {
      TransformMesh(rotation.cast<float>(), translation.cast<float>(), &part.mesh);
      scene.objects.push_back(std::move(part));
    }
  }
  if (scene.objects.empty()) root.Fail("objects", "expected at least one object");
  // A point light inside the scene's bounding sphere would sit inside or
  // among the objects, where the shadow map's view of them breaks down.
  const auto [centre, radius] = scene.Bounds();
  const double distance = (scene.light.position - centre).norm();
  if (!(distance > radius)) {
    std::ostringstream problem;
    problem << "expected a point outside the scene's bounding sphere (centre [" << centre.x() << ", " << centre.y()
            << ", " << centre.z() << "], radius " << radius << " mm), got one " << distance << " mm from its centre";
    root.Object("light").Fail("position", problem.str());
  }
  return scene;
}

}  // namespace mesocap::render
