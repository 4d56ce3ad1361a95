// An OpenGL 4.5 core context, headless or in a window, behind one interface
// so that the renderer has a single code path: the
// renderer always draws into its own framebuffer objects; a window only
// shows the result.
//
// Headless: EGL on Mesa's surfaceless platform (llvmpipe or a GPU driver), or
// an EGL device (NVIDIA) when the surfaceless platform is missing. Windowed:
// GLFW. GL entry points are loaded by libepoxy.
#pragma once

#include <memory>
#include <string>

struct GLFWwindow;

namespace mesocap::render {

class GlContext {
 public:
  virtual ~GlContext() = default;
  // A headless context. Throws Error naming what is missing (no EGL display,
  // no surfaceless platform or EGL device, no OpenGL 4.5 core context).
  static std::unique_ptr<GlContext> MakeHeadless();
  // A window of the given size with the context current. Throws Error when
  // there is no display (DISPLAY / WAYLAND_DISPLAY unset) or GLFW cannot make
  // a 4.5 core context.
  static std::unique_ptr<GlContext> MakeWindow(int width, int height, const std::string& title);

  // "Mesa llvmpipe (LLVM 15.0.6, 256 bits) / OpenGL 4.5 (Core Profile) Mesa 22.3.6".
  std::string Description() const;
  // The window, nullptr when headless.
  virtual GLFWwindow* window() const { return nullptr; }
};

}  // namespace mesocap::render
