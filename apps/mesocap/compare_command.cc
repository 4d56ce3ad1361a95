// `mesocap compare SCENE [--json]`: renders every mode and the CPU reference
// and prints the error table (the paper's Fig. 10 comparison, measured):
// coverage IoU (silhouettes), shadow-mask IoU, PSNR, frame time (median of
// --repeat frames) and peel passes per mode.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <vector>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "apps/mesocap/render_scene_option.h"
#include "core/error.h"
#include "core/image_io.h"
#include "render/gl_context.h"
#include "render/image_comparison.h"
#include "render/peeling_renderer.h"
#include "render/reference_renderer.h"

namespace mesocap {
namespace {

struct CompareCommandOptions {
  RenderSceneOptions scene;
  bool json = false;
  int repeat = 5;
  std::filesystem::path images;  // empty: write no images
};

// --images DIR: one renderer's (a mode's, or the reference's) colour,
// coverage and shadow images as NAME_color.png etc.
void WriteRenderImages(const std::filesystem::path& dir, const std::string& name, const core::Image& color,
                       const core::Image& coverage, const core::Image& shadow) {
  core::WriteImage(dir / (name + "_color.png"), color, core::PixelEncoding::kUInt8);
  core::WriteImage(dir / (name + "_coverage.png"), coverage, core::PixelEncoding::kUInt8);
  core::WriteImage(dir / (name + "_shadow.png"), shadow, core::PixelEncoding::kUInt8);
}

// A mode's images and where its masks disagree with the reference's.
void WriteComparisonImages(const std::filesystem::path& dir, const std::string& name, const render::RenderResult& r,
                           const render::ReferenceImage& truth) {
  WriteRenderImages(dir, name, r.color, r.coverage, r.shadow);
  core::WriteImage(dir / (name + "_coverage_difference.png"),
                   render::MaskDifference(r.coverage, truth.coverage, truth.color), core::PixelEncoding::kUInt8);
  core::WriteImage(dir / (name + "_shadow_difference.png"), render::MaskDifference(r.shadow, truth.shadow, truth.color),
                   core::PixelEncoding::kUInt8);
}

void RunCompare(const CompareCommandOptions& o) {
  const render::PeelingOptions base = o.scene.Peeling();
  const render::RenderScene scene = render::ReadRenderScene(o.scene.scene, ResolveRenderMaterial);
  const auto context = render::GlContext::MakeHeadless();
  render::PeelingRenderer renderer(scene);
  const auto start = std::chrono::steady_clock::now();
  const render::ReferenceRenderer reference(scene);
  const render::ReferenceImage truth = reference.Render(scene.camera, scene.light, base.width, base.height);
  const double reference_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!o.images.empty()) {
    std::filesystem::create_directories(o.images);
    WriteRenderImages(o.images, "reference", truth.color, truth.coverage, truth.shadow);
  }
  nlohmann::json report = {{"scene", o.scene.scene.string()},
                           {"size", {base.width, base.height}},
                           {"device", context->Description()},
                           {"reference_ms", reference_ms},
                           {"reference_triangles", reference.triangle_count()}};
  for (const render::RenderMode mode :
       {render::RenderMode::kBtf, render::RenderMode::kSilhouette, render::RenderMode::kFull}) {
    render::PeelingOptions options = base;
    options.mode = mode;
    const render::RenderResult result = renderer.Render(scene.camera, scene.light, options);
    if (!o.images.empty()) WriteComparisonImages(o.images, render::ToString(mode), result, truth);
    std::vector<double> times;
    for (int i = 0; i < o.repeat; ++i) times.push_back(renderer.Draw(scene.camera, scene.light, options).frame_ms);
    std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
    report[render::ToString(mode)] = {{"coverage_iou", render::MaskIou(result.coverage, truth.coverage)},
                                      {"shadow_iou", render::MaskIou(result.shadow, truth.shadow)},
                                      {"psnr_db", render::Psnr(result.color, truth.color)},
                                      {"frame_ms", times[times.size() / 2]},
                                      {"passes", result.passes},
                                      {"shadow_passes", result.shadow_passes}};
  }
  if (o.json) {
    std::printf("%s\n", report.dump(2).c_str());
    return;
  }
  std::printf("%s at %dx%d on %s (reference: %.0f ms, %zu triangles)\n", o.scene.scene.string().c_str(), base.width,
              base.height, context->Description().c_str(), reference_ms, reference.triangle_count());
  std::printf("%-11s %12s %10s %8s %10s %7s %7s\n", "mode", "coverage IoU", "shadow IoU", "PSNR dB", "frame ms",
              "passes", "ratio");
  const double btf_ms = report["btf"]["frame_ms"].get<double>();
  for (const char* mode : {"btf", "silhouette", "full"}) {
    const auto& m = report[mode];
    std::printf("%-11s %12.4f %10.4f %8.2f %10.2f %3d/%-3d %7.2f\n", mode, m["coverage_iou"].get<double>(),
                m["shadow_iou"].get<double>(), m["psnr_db"].get<double>(), m["frame_ms"].get<double>(),
                m["passes"].get<int>(), m["shadow_passes"].get<int>(), m["frame_ms"].get<double>() / btf_ms);
  }
}

}  // namespace

void RegisterCompareCommand(CLI::App& app) {
  auto o = std::make_shared<CompareCommandOptions>();
  CLI::App* sub = app.add_subcommand("compare", HelpText("compare"));
  AddRenderSceneOptions(sub, &o->scene);
  sub->add_flag("--json", o->json, "print one JSON object with a member per mode (btf, silhouette, full)");
  sub->add_option("--repeat", o->repeat, "frames timed per mode (the median is reported)")
      ->check(InRange(1, 1000))
      ->capture_default_str();
  sub->add_option("--images", o->images,
                  "folder to write every mode's colour, coverage and shadow images, the reference's, and "
                  "*_difference.png (red: reference only, green: rendered only)");
  sub->callback([o] { RunCompare(*o); });
}

}  // namespace mesocap
