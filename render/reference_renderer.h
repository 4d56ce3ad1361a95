// The CPU reference renderer: the true image of a
// scene, ray traced with Embree through the real displaced geometry. The
// mesostructure tiles of each object's material are mapped onto its mesh
// through the same texture coordinates the GL renderer uses: the mesh is the
// reference surface and a sample point (x, y, z), z <= 0, goes to
// S(u, v) + s z N(u, v) with the interpolated normal N and texture scale s, so
// both renderers place detail identically and differ only by what the MDF
// approximates.
//
// What the masks mean, matching the GL renderer's: coverage = a ray hits
// geometry; shadow = the shown point is in macroscale shadow, i.e. the base
// surface faces away from the light, or the shadow ray is blocked beyond the
// point where it leaves the mesostructure slab through the reference surface
// (a blocker inside the slab is mesoscale self-shadowing, which the BTF
// holds; the GL shadow map stores the slab's far side along the light).
// Shading: lit points get f_r (n . l) I / r^2 with the true normal (zero when
// self-shadowed), macroscale-shadowed points ambient * La, as in Sec. 4.2.
#pragma once

#include <memory>

#include "core/image.h"
#include "render/render_scene.h"

namespace mesocap::render {

struct ReferenceImage {
  core::Image color;     // 3 channels, radiance times exposure, origin top-left
  core::Image coverage;  // 1 channel
  core::Image shadow;    // 1 channel
};

class ReferenceRenderer {
 public:
  // Builds the displaced geometry and its Embree scene. Throws Error when an
  // object's material has no geometry (a measured material has no truth).
  explicit ReferenceRenderer(const RenderScene& scene);
  ~ReferenceRenderer();
  ReferenceRenderer(const ReferenceRenderer&) = delete;
  ReferenceRenderer& operator=(const ReferenceRenderer&) = delete;

  // One ray through each pixel centre, the GL renderer's projection.
  ReferenceImage Render(const SceneCamera& camera, const SceneLight& light, int width, int height) const;
  // Triangles of the displaced geometry (with the plain objects').
  std::size_t triangle_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mesocap::render
