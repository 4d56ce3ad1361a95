// The procedural scenes. Sizes are in mm and chosen so that a small rig's
// sample (20-40 mm) shows several tiles; mesostructure_scene.h lists what
// each is for.
#include "sim/builtin_scenes.h"

#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>

#include "core/error.h"
#include "sim/tiled_scene.h"

namespace mesocap::sim {
namespace {

constexpr double kPi = std::numbers::pi;

// A deterministic value in [0, 1) for `key` (splitmix64 finalizer): the
// scenes must be identical on every machine and every run.
double Hash01(std::uint64_t key) {
  std::uint64_t z = key + 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1p-53;
}

Reflectance Diffuse(float r, float g, float b) {
  Reflectance reflectance;
  reflectance.diffuse_albedo = {r, g, b};
  return reflectance;
}

Reflectance Glossy(float r, float g, float b, float specular_albedo, float exponent) {
  Reflectance reflectance = Diffuse(r, g, b);
  reflectance.specular_albedo = specular_albedo;
  reflectance.glossy_exponent = exponent;
  return reflectance;
}

// `base` scaled by a per-object factor in [1 - spread, 1 + spread].
Reflectance Tinted(Reflectance base, std::uint64_t key, float spread) {
  base.diffuse_albedo *= 1.0f + spread * static_cast<float>(2.0 * Hash01(key) - 1.0);
  base.diffuse_albedo = base.diffuse_albedo.cwiseMin(1.0f);
  return base;
}

// Faces of an axis-aligned box; faces hidden by the tiling or by the base are left out.
enum BoxFaces : unsigned { kTop = 1, kBottom = 2, kFacesX = 4, kFacesY = 8 };

void AddBox(TileGeometry& g, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int part, unsigned faces) {
  const auto corner = [&](int ix, int iy, int iz) {
    return g.AddVertex({ix ? hi.x() : lo.x(), iy ? hi.y() : lo.y(), iz ? hi.z() : lo.z()});
  };
  if (faces & kTop) g.AddQuad(corner(0, 0, 1), corner(1, 0, 1), corner(1, 1, 1), corner(0, 1, 1), part);
  if (faces & kBottom) g.AddQuad(corner(0, 0, 0), corner(0, 1, 0), corner(1, 1, 0), corner(1, 0, 0), part);
  if (faces & kFacesX) {
    g.AddQuad(corner(0, 0, 0), corner(0, 0, 1), corner(0, 1, 1), corner(0, 1, 0), part);
    g.AddQuad(corner(1, 0, 0), corner(1, 1, 0), corner(1, 1, 1), corner(1, 0, 1), part);
  }
  if (faces & kFacesY) {
    g.AddQuad(corner(0, 0, 0), corner(1, 0, 0), corner(1, 0, 1), corner(0, 0, 1), part);
    g.AddQuad(corner(0, 1, 0), corner(0, 1, 1), corner(1, 1, 1), corner(1, 1, 0), part);
  }
}

// A tube across the whole tile along x (axis 0) or y (axis 1), at `offset`
// in the other horizontal coordinate, with a circular cross-section of
// `radius` in the plane normal to the axis around the height centre_z(s).
// centre_z must be P-periodic; the open ends meet the neighbouring copies.
void AddTube(TileGeometry& g, int axis, double offset, const std::function<double(double)>& centre_z, double radius,
             int segments, int sides, int part) {
  const double p = g.tile_size_mm;
  const int first = static_cast<int>(g.vertices.size());
  for (int k = 0; k <= segments; ++k) {
    const double s = p * (static_cast<double>(k) / segments);  // exactly P at k = segments
    const double z = centre_z(p * (static_cast<double>(k % segments) / segments));
    for (int m = 0; m < sides; ++m) {
      // Ring vertex 0 at the top, so the tube's top is exactly z + radius.
      const double angle = kPi / 2.0 + 2.0 * kPi * m / sides;
      const double across = offset + radius * std::cos(angle);
      const double height = m == 0 ? z + radius : z + radius * std::sin(angle);
      g.AddVertex(axis == 0 ? Eigen::Vector3d(s, across, height) : Eigen::Vector3d(across, s, height));
    }
  }
  for (int k = 0; k < segments; ++k) {
    for (int m = 0; m < sides; ++m) {
      const int a = first + k * sides + m;
      const int b = first + k * sides + (m + 1) % sides;
      g.AddQuad(a, b, b + sides, a + sides, part);
    }
  }
}

TileGeometry Flat() {
  TileGeometry g{.name = "flat", .tile_size_mm = 5.0, .d_max_mm = 1.0};
  g.AddBase(0.0, g.AddPart(Diffuse(0.5f, 0.5f, 0.5f)));
  return g;
}

TileGeometry Box() {
  TileGeometry g{.name = "box", .tile_size_mm = 5.0, .d_max_mm = 1.0};
  g.AddBase(-1.0, g.AddPart(Diffuse(0.45f, 0.42f, 0.38f)));
  AddBox(g, {1.5, 1.5, -1.0}, {3.5, 3.5, 0.0}, g.AddPart(Diffuse(0.7f, 0.25f, 0.2f)), kTop | kFacesX | kFacesY);
  return g;
}

TileGeometry Blocks() {
  TileGeometry g{.name = "blocks", .tile_size_mm = 9.0, .d_max_mm = 2.0, .albedo_variation = 0.15f};
  g.AddBase(-2.0, g.AddPart(Diffuse(0.35f, 0.35f, 0.35f)));
  constexpr double kHeights[9] = {2.0, 1.2, 0.6, 1.6, 0.9, 1.4, 0.4, 1.8, 1.0};
  const Reflectance colours[3] = {Glossy(0.7f, 0.3f, 0.2f, 0.15f, 40.0f), Glossy(0.25f, 0.5f, 0.7f, 0.15f, 40.0f),
                                  Glossy(0.75f, 0.7f, 0.3f, 0.15f, 40.0f)};
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) {
      const int k = 3 * j + i;
      const int part = g.AddPart(Tinted(colours[k % 3], k, 0.15f));
      const double x = 3.0 * i + 0.4;
      const double y = 3.0 * j + 0.4;
      AddBox(g, {x, y, -2.0}, {x + 2.2, y + 2.2, kHeights[k] - 2.0}, part, kTop | kFacesX | kFacesY);
    }
  }
  return g;
}

TileGeometry Brick() {
  TileGeometry g{.name = "brick", .tile_size_mm = 8.0, .d_max_mm = 0.5, .albedo_variation = 0.1f};
  g.AddBase(-0.5, g.AddPart(Diffuse(0.6f, 0.58f, 0.55f)));  // the mortar
  // Running bond: 4 courses of 2 bricks (4 x 2 mm pitch, 0.4 mm joints),
  // odd courses shifted by half a brick, so one brick of each crosses x = P.
  for (int course = 0; course < 4; ++course) {
    const double shift = course % 2 == 1 ? 2.0 : 0.0;
    for (int k = 0; k < 2; ++k) {
      const int part = g.AddPart(Tinted(Diffuse(0.55f, 0.22f, 0.15f), 100 + 2 * course + k, 0.2f));
      const double x = shift + 4.0 * k + 0.2;
      const double y = 2.0 * course + 0.2;
      AddBox(g, {x, y, -0.5}, {x + 3.6, y + 1.6, 0.0}, part, kTop | kFacesX | kFacesY);
    }
  }
  return g;
}

TileGeometry Weave() {
  TileGeometry g{.name = "weave", .tile_size_mm = 4.0, .d_max_mm = 3.0, .albedo_variation = 0.1f};
  g.AddBase(-3.0, g.AddPart(Diffuse(0.05f, 0.05f, 0.05f)));  // dark backing
  // Plain weave, thread pitch s = 2 mm: warp j (along x, at y = 1 + 2j) is
  // over weft i (along y, at x = 1 + 2i) where i + j is even. The centre
  // lines swing by +-A about zc; A > r leaves a 0.1 mm gap at each crossing.
  constexpr double kPitch = 2.0, kRadius = 0.6, kSwing = 0.65, kCentre = -(kSwing + kRadius);
  const Reflectance warp = Glossy(0.2f, 0.3f, 0.6f, 0.1f, 8.0f);
  const Reflectance weft = Glossy(0.75f, 0.7f, 0.55f, 0.1f, 8.0f);
  for (int n = 0; n < 2; ++n) {
    const double at = 1.0 + kPitch * n;
    const double phase = kPi * n;
    AddTube(
        g, 0, at, [&](double x) { return kCentre + kSwing * std::cos(kPi * (x - 1.0) / kPitch + phase); }, kRadius, 96,
        24, g.AddPart(Tinted(warp, 200 + n, 0.1f)));
    AddTube(
        g, 1, at, [&](double y) { return kCentre - kSwing * std::cos(kPi * (y - 1.0) / kPitch + phase); }, kRadius, 96,
        24, g.AddPart(Tinted(weft, 210 + n, 0.1f)));
  }
  return g;
}

TileGeometry Pipes() {
  TileGeometry g{.name = "pipes", .tile_size_mm = 6.0, .d_max_mm = 2.6, .albedo_variation = 0.1f};
  g.AddBase(-2.6, g.AddPart(Diffuse(0.4f, 0.4f, 0.4f)));
  // Two pipes along x held 0.6 mm above the base: the space under them is
  // seen only from oblique directions (undercuts).
  AddTube(
      g, 0, 1.5, [](double) { return -1.0; }, 1.0, 1, 48, g.AddPart(Glossy(0.6f, 0.35f, 0.2f, 0.4f, 60.0f)));
  AddTube(
      g, 0, 4.5, [](double) { return -1.2; }, 0.8, 1, 48, g.AddPart(Glossy(0.3f, 0.5f, 0.35f, 0.2f, 30.0f)));
  return g;
}

TileGeometry Grass() {
  constexpr double kTallest = 2.0;
  TileGeometry g{.name = "grass", .tile_size_mm = 4.0, .d_max_mm = kTallest, .albedo_variation = 0.1f};
  g.AddBase(-kTallest, g.AddPart(Diffuse(0.25f, 0.18f, 0.1f)));  // soil
  const Reflectance green = Glossy(0.15f, 0.45f, 0.1f, 0.05f, 20.0f);
  for (std::uint64_t k = 0; k < 24; ++k) {
    const auto random = [&](std::uint64_t field) { return Hash01(1000 * k + field); };
    const Eigen::Vector3d root(4.0 * random(0), 4.0 * random(1), -kTallest);
    const double height = k == 0 ? kTallest : 1.0 + 1.0 * random(2);  // blade 0 touches z = 0
    const double facing = 2.0 * kPi * random(3);
    const double half_width = 0.05 + 0.03 * random(4);
    const double lean_azimuth = 2.0 * kPi * random(5);
    const double lean = 0.15 + 0.35 * random(6);
    const Eigen::Vector3d across(half_width * std::cos(facing), half_width * std::sin(facing), 0.0);
    const Eigen::Vector3d bend(std::cos(lean_azimuth), std::sin(lean_azimuth), 0.0);
    // A thin blade bending over: a quad up to 55% of its height, then a tip.
    const Eigen::Vector3d mid = root + Eigen::Vector3d(0, 0, 0.55 * height) + 0.3 * lean * bend;
    const Eigen::Vector3d tip = root + Eigen::Vector3d(0, 0, height) + lean * bend;
    const int part = g.AddPart(Tinted(green, 300 + k, 0.3f));
    const int a = g.AddVertex(root - across), b = g.AddVertex(root + across);
    const int c = g.AddVertex(mid + 0.7 * across), d = g.AddVertex(mid - 0.7 * across);
    g.AddQuad(a, b, c, d, part);
    g.AddTriangle(d, c, g.AddVertex(tip), part);
  }
  return g;
}

TileGeometry Sponge() {
  TileGeometry g{.name = "sponge", .tile_size_mm = 4.0, .d_max_mm = 1.2, .albedo_variation = 0.15f};
  // A two-layer lattice (woodpile) with no base: bars 0.8 mm wide and thick
  // 0.6 mm along x on top, along y below. The open squares, such as the
  // vertical line through (2, 1), go right through the slab.
  const int top = g.AddPart(Diffuse(0.8f, 0.75f, 0.5f));
  const int bottom = g.AddPart(Diffuse(0.65f, 0.6f, 0.4f));
  const double p = g.tile_size_mm;
  for (const double y : {0.0, 2.0}) {
    AddBox(g, {0.0, y - 0.4, -0.6}, {p, y + 0.4, 0.0}, top, kTop | kBottom | kFacesY);
  }
  for (const double x : {1.0, 3.0}) {
    AddBox(g, {x - 0.4, 0.0, -1.2}, {x + 0.4, p, -0.6}, bottom, kTop | kBottom | kFacesX);
  }
  return g;
}

struct BuiltinScene {
  const char* name;
  TileGeometry (*make)();
};

constexpr BuiltinScene kScenes[] = {{"flat", Flat},   {"box", Box},     {"blocks", Blocks}, {"brick", Brick},
                                    {"weave", Weave}, {"pipes", Pipes}, {"grass", Grass},   {"sponge", Sponge}};

}  // namespace

std::vector<std::string> BuiltinSceneNames() {
  std::vector<std::string> names;
  for (const BuiltinScene& scene : kScenes) names.emplace_back(scene.name);
  return names;
}

TileGeometry BuiltinTileGeometry(const std::string& name) {
  for (const BuiltinScene& scene : kScenes) {
    if (name == scene.name) return scene.make();
  }
  std::string known;
  for (const BuiltinScene& scene : kScenes) known += std::string(known.empty() ? "" : ", ") + scene.name;
  throw core::Error("unknown scene '" + name + "'; built-in scenes: " + known);
}

std::unique_ptr<MesostructureScene> MakeBuiltinScene(const std::string& name) {
  return MakeTiledScene(BuiltinTileGeometry(name));
}

}  // namespace mesocap::sim
