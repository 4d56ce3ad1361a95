// The real-time renderer of Wang et al. 2005 Sec. 4-5 on OpenGL 4.5 core:
// BTF shading from the SVD factors (Sec. 5), mesostructure silhouettes by
// front-to-back depth peeling with the MDF (Sec. 4.1, Fig. 7), and shadow
// silhouettes and shadow casting through a shadow map peeled the same way
// from the light (Sec. 4.2). Needs a current context (GlContext); draws into
// its own framebuffer objects, so headless and windowed use share this path.
#pragma once

#include <memory>
#include <string>

#include "core/enum_text.h"
#include "core/error.h"
#include "core/image.h"
#include "render/render_scene.h"

namespace mesocap::render {

// The paper's Table 2 columns: BTF only; + object silhouettes; + shadow
// silhouettes and MDF shadow casting.
enum class RenderMode { kBtf, kSilhouette, kFull };
constexpr auto EnumNamesOf(RenderMode) { return std::to_array({"btf", "silhouette", "full"}); }
using core::ToString;

struct PeelingOptions {
  RenderMode mode = RenderMode::kFull;
  // Peel passes: 0 = adaptive (stop when a pass finds no further layer for
  // any unfinished pixel: an occlusion query on the back-face pass), else
  // exactly this many.
  int passes = 0;
  int max_passes = 64;  // adaptive cap (the stencil holds 254 passes)
  int width = 800;
  int height = 600;
  int shadow_map_size = 1024;

  core::CheckResult Check() const;
};

struct RenderResult {
  core::Image color;      // 3 channels, linear radiance times the scene's exposure, origin top-left
  core::Image coverage;   // 1 channel: 1 where a surface is shown
  core::Image shadow;     // 1 channel: 1 where the shown point is in macroscale shadow (shaded with La)
  int passes = 0;         // view peel passes run (1 for BTF only)
  int shadow_passes = 0;  // light peel passes run (1 for a plain shadow map)
  double frame_ms = 0.0;  // shadow map + view, GPU finished (glFinish), without read-back
};

class PeelingRenderer {
 public:
  // Uploads the meshes and materials. Throws Error when the context lacks
  // something (texture array layers for the BTF) or a shader fails.
  explicit PeelingRenderer(const RenderScene& scene);
  ~PeelingRenderer();
  PeelingRenderer(const PeelingRenderer&) = delete;
  PeelingRenderer& operator=(const PeelingRenderer&) = delete;

  RenderResult Render(const SceneCamera& camera, const SceneLight& light, const PeelingOptions& options);
  // Draws the last frame without reading it back (the viewer); returns frame_ms and passes in `result`
  // with empty images.
  RenderResult Draw(const SceneCamera& camera, const SceneLight& light, const PeelingOptions& options);
  // Copies the last frame's colour into the default framebuffer (a window).
  void Present(int window_width, int window_height);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mesocap::render
