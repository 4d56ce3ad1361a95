// `mesocap render SCENE --out IMG [--mode btf|silhouette|full] [--passes
// auto|N] [--size WxH]`: one headless frame of the depth-peeling renderer.
#include <spdlog/spdlog.h>

#include <filesystem>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "apps/mesocap/render_scene_option.h"
#include "core/error.h"
#include "core/image_io.h"
#include "render/gl_context.h"
#include "render/peeling_renderer.h"

namespace mesocap {
namespace {

struct RenderCommandOptions {
  RenderSceneOptions scene;
  std::filesystem::path out;
  std::string mode = "full";
  bool replace = false;
};

core::PixelEncoding EncodingFor(const std::filesystem::path& file) {
  const std::string ext = file.extension().string();
  if (ext == ".exr") return core::PixelEncoding::kFloat32;
  if (ext == ".png" || ext == ".tif" || ext == ".tiff") return core::PixelEncoding::kUInt8;
  throw core::Error("--out " + file.string() + ": expected a .png, .tif or .exr file");
}

void RunRender(const RenderCommandOptions& o) {
  render::PeelingOptions peeling = o.scene.Peeling();
  peeling.mode = core::ParseEnum<render::RenderMode>(o.mode, "render mode");
  const core::PixelEncoding encoding = EncodingFor(o.out);
  ExpectReplaceableFile(o.out, o.replace, "an image", core::IsImageFile, {o.scene.scene});
  const render::RenderScene scene = render::ReadRenderScene(o.scene.scene, ResolveRenderMaterial);
  std::vector<std::filesystem::path> inputs{o.scene.scene};
  for (const render::RenderMaterial& m : scene.materials) inputs.push_back(m.package);
  ExpectReplaceableFile(o.out, o.replace, "an image", core::IsImageFile,
                        inputs);  // never a file of a package the scene uses
  const auto context = render::GlContext::MakeHeadless();
  spdlog::info("OpenGL: {}", context->Description());
  render::PeelingRenderer renderer(scene);
  const render::RenderResult result = renderer.Render(scene.camera, scene.light, peeling);
  core::WriteImage(o.out, result.color, encoding);
  spdlog::info("{} {}x{} mode {}: {:.2f} ms, {} view passes, {} shadow passes -> {}", o.scene.scene.string(),
               peeling.width, peeling.height, o.mode, result.frame_ms, result.passes, result.shadow_passes,
               o.out.string());
}

}  // namespace

void RegisterRenderCommand(CLI::App& app) {
  auto o = std::make_shared<RenderCommandOptions>();
  CLI::App* sub = app.add_subcommand("render", HelpText("render"));
  AddRenderSceneOptions(sub, &o->scene);
  sub->add_option("--out", o->out, "image to write (.png, .tif: 8-bit; .exr: linear float)")->required();
  sub->add_option("--mode", o->mode, "btf, silhouette (+ MDF object silhouettes) or full (+ MDF shadows)")
      ->check(CLI::IsMember({"btf", "silhouette", "full"}))
      ->capture_default_str();
  sub->add_flag("--replace", o->replace, "replace an existing image at --out");
  sub->callback([o] { RunRender(*o); });
}

}  // namespace mesocap
