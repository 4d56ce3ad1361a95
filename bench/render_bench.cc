// Speed against error of the depth-peeling renderer (issue 6, deliverable 8;
// the paper's Table 2): for each shipped scene at 800x600, the frame time of
// BTF only, + MDF object silhouettes, + MDF shadow silhouettes and shadow
// casting, as a ratio to BTF only measured in the same run (the bound: a
// frame can hardly cost less than its BTF shading), the peel passes used,
// and against the CPU reference on the same frame: coverage IoU, shadow-mask
// IoU and PSNR.
//
// Materials: the scenes' sim: materials with their true MDF (64 x 64 texels,
// 12 x 8 views) and a Lambertian BTF made by hand, stored at rank 4 (the
// paper's rank) so that the shader does the work of a rank-4 BTF: factor 0
// is the Lambertian value, factors 1-3 are zero. Real factored BTFs need the
// BTF compression step; the frame time depends on the rank, not the values.
// manual time = frame_ms (shadow map + view, glFinish-bracketed).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "render/gl_context.h"
#include "render/image_comparison.h"
#include "render/peeling_renderer.h"
#include "render/reference_renderer.h"
#include "tests/render/lambertian_material.h"

namespace {

using namespace mesocap::render;

constexpr int kWidth = 800, kHeight = 600;

struct SceneRun {
  RenderScene scene;
  std::unique_ptr<PeelingRenderer> renderer;
  ReferenceImage truth;
};

GlContext& Context() {
  static const std::unique_ptr<GlContext> context = GlContext::MakeHeadless();
  return *context;
}

SceneRun& Run(const std::string& name) {
  Context();  // first, so that it outlives the renderers (statics die in reverse order)
  static std::map<std::string, std::unique_ptr<SceneRun>> runs;
  auto& run = runs[name];
  if (!run) {
    run = std::make_unique<SceneRun>();
    run->scene = ReadRenderScene(std::filesystem::path(MESOCAP_SOURCE_DIR) / "render/scenes" / (name + ".json"),
                                 [](const std::string& spec, const std::filesystem::path&) {
                                   RenderMaterial m = LambertianSimMaterial(spec.substr(4), 64);
                                   const mesocap::Image zero(m.btf.rows[0].width(), m.btf.rows[0].height(), 3, 0.0f);
                                   m.btf.rows.resize(4, zero);
                                   mesocap::Image columns(m.btf.columns.width(), 4, 3, 0.0f);
                                   for (int x = 0; x < columns.width(); ++x)
                                     for (int c = 0; c < 3; ++c) columns.at(x, 0, c) = 1.0f;
                                   m.btf.columns = columns;
                                   return m;
                                 });
    run->renderer = std::make_unique<PeelingRenderer>(run->scene);
    run->truth = ReferenceRenderer(run->scene).Render(run->scene.camera, run->scene.light, kWidth, kHeight);
  }
  return *run;
}

double MedianFrameMs(PeelingRenderer& renderer, const RenderScene& scene, const PeelingOptions& o, int frames) {
  std::vector<double> t;
  for (int i = 0; i < frames; ++i) t.push_back(renderer.Draw(scene.camera, scene.light, o).frame_ms);
  std::nth_element(t.begin(), t.begin() + t.size() / 2, t.end());
  return t[t.size() / 2];
}

void Frame(benchmark::State& state, const std::string& name, RenderMode mode) {
  SceneRun& run = Run(name);
  PeelingOptions o;
  o.mode = mode;
  o.width = kWidth;
  o.height = kHeight;
  const RenderResult first = run.renderer->Render(run.scene.camera, run.scene.light, o);
  std::vector<double> times;
  for (auto _ : state) {
    const RenderResult r = run.renderer->Draw(run.scene.camera, run.scene.light, o);
    state.SetIterationTime(r.frame_ms / 1000.0);
    times.push_back(r.frame_ms);
  }
  std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
  PeelingOptions btf = o;
  btf.mode = RenderMode::kBtf;
  const double btf_ms = MedianFrameMs(*run.renderer, run.scene, btf, static_cast<int>(times.size()));
  state.counters["frame_ms"] = times[times.size() / 2];
  state.counters["ratio_to_btf"] = times[times.size() / 2] / btf_ms;
  state.counters["passes"] = first.passes;
  state.counters["shadow_passes"] = first.shadow_passes;
  state.counters["coverage_iou"] = MaskIou(first.coverage, run.truth.coverage);
  state.counters["shadow_iou"] = MaskIou(first.shadow, run.truth.shadow);
  state.counters["psnr_db"] = Psnr(first.color, run.truth.color);
  state.SetLabel(Context().Description());
}

const bool registered = [] {
  for (const char* scene : {"cylinder", "torus_8x3", "torus_6x2", "torus_3x1", "torus_2x1", "torus_knot"}) {
    for (const RenderMode mode : {RenderMode::kBtf, RenderMode::kSilhouette, RenderMode::kFull}) {
      benchmark::RegisterBenchmark((std::string("Frame/") + scene + "/" + ToString(mode)).c_str(),
                                   [scene, mode](benchmark::State& s) { Frame(s, scene, mode); })
          ->UseManualTime()
          ->Iterations(7)
          ->Unit(benchmark::kMillisecond);
    }
  }
  return true;
}();

}  // namespace

BENCHMARK_MAIN();
