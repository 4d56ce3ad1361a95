#include "apps/mesocap/render_scene_option.h"

#include <spdlog/spdlog.h>

#include <charconv>
#include <cstdlib>

#include "apps/mesocap/command.h"
#include "core/error.h"
#include "formats/material_manifest.h"
#include "pipelines/compress.h"
#include "render/sim_material.h"
#include "sim/builtin_scenes.h"
#include "sim/ground_truth.h"
#include "sim/mesostructure_scene.h"

namespace mesocap {
namespace {

int ParseInt(const std::string& text, const std::string& flag) {
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size()) {
    throw core::Error(flag + ": expected a whole number, got " + core::Quoted(text));
  }
  return value;
}

std::filesystem::path CacheDir() {
  if (const char* dir = std::getenv("MESOCAP_CACHE_DIR"); dir != nullptr && *dir != '\0') return dir;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg != nullptr && *xdg != '\0') {
    return std::filesystem::path(xdg) / "mesocap";
  }
  if (const char* home = std::getenv("HOME"); home != nullptr && *home != '\0') {
    return std::filesystem::path(home) / ".cache" / "mesocap";
  }
  throw core::Error("sim materials: no cache folder (set MESOCAP_CACHE_DIR, XDG_CACHE_HOME or HOME)");
}

// The rank the built-in materials are factored to: the renderer's cost grows
// with it, and 8 terms keep the brick and blocks BTFs' shading structure.
constexpr int kSimMaterialRank = 8;
// Part of the cache folder's name: changed whenever what a built-in material
// holds changes (v3: 24 view azimuths instead of 12), so an older cache is
// never read as the new one.
constexpr const char* kSimMaterialCacheVersion = "v3";

}  // namespace

render::PeelingOptions RenderSceneOptions::Peeling() const {
  render::PeelingOptions o;
  const std::size_t x = size.find('x');
  if (x == std::string::npos) throw core::Error("--size: expected WIDTHxHEIGHT, got " + core::Quoted(size));
  o.width = ParseInt(size.substr(0, x), "--size");
  o.height = ParseInt(size.substr(x + 1), "--size");
  if (o.width < 1 || o.height < 1 || o.width > 8192 || o.height > 8192) {
    throw core::Error("--size: expected each side in [1, 8192], got " + core::Quoted(size));
  }
  o.passes = passes == "auto" ? 0 : ParseInt(passes, "--passes");
  if (passes != "auto" && (o.passes < 1 || o.passes > 254)) {
    throw core::Error("--passes: expected auto or a count in [1, 254], got " + core::Quoted(passes));
  }
  o.shadow_map_size = shadow_map_size;
  core::ThrowIfInvalid(o.Check(), "render");
  return o;
}

void AddRenderSceneOptions(CLI::App* command, RenderSceneOptions* options) {
  command->add_option("scene", options->scene, "render scene file (render/scenes/*.json)")->required();
  command->add_option("--size", options->size, "image size WIDTHxHEIGHT")->capture_default_str();
  command->add_option("--passes", options->passes, "peel passes: auto (until nothing is left) or a count")
      ->capture_default_str();
  command->add_option("--shadow-map", options->shadow_map_size, "shadow map size (texels per side)")
      ->check(InRange(16, 8192))
      ->capture_default_str();
}

render::RenderMaterial ResolveRenderMaterial(const std::string& spec, const std::filesystem::path& scene_dir) {
  if (spec.rfind("sim:", 0) != 0) return render::ResolvePackageMaterial(spec, scene_dir);
  const std::string name = spec.substr(4);
  const sim::TileGeometry geometry = sim::BuiltinTileGeometry(name);  // throws for an unknown name
  const std::filesystem::path package = CacheDir() / "materials" / (name + "-" + kSimMaterialCacheVersion);
  if (!std::filesystem::exists(package / "manifest.json")) {
    // Ground truth (full BTF, MDF, ambient term), then its BTF factored at a
    // fixed rank, as a measured material would be (Sec. 5); the full-BTF
    // package is only a step on the way.
    const std::filesystem::path truth = package.string() + "-truth";
    const auto scene = sim::MakeBuiltinScene(name);
    spdlog::info("building material {} from ground truth into {}", spec, package.string());
    sim::WriteGroundTruthPackage(*scene, render::SimMaterialGroundTruthOptions(name), nullptr,
                                 "groundtruth scene=" + name + " for render", truth, true);
    pipelines::CompressOptions compress;
    compress.in = truth;
    compress.out = package;
    compress.compression.rank = kSimMaterialRank;
    compress.replace = true;
    pipelines::RunCompress(compress);
    std::filesystem::remove_all(truth);
  }
  if (!formats::ReadMaterialManifest(package).factored_btf) {
    throw core::Error("material " + spec + ": the cached package " + package.string() +
                      " has no factored BTF; remove it to have it built again");
  }
  render::RenderMaterial material = render::LoadRenderMaterial(package);
  material.geometry = geometry;
  return material;
}

}  // namespace mesocap
