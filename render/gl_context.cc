#include "render/gl_context.h"

#include <epoxy/egl.h>
#include <epoxy/gl.h>

#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cstdlib>
#include <vector>

#include "core/error.h"

namespace mesocap::render {
namespace {

// The context must provide what the renderer uses: 4.5 core (texelFetch on
// 2D arrays, float depth with stencil, occlusion queries, gl_FragDepth).
void ExpectGl45(const std::string& where) {
  if (epoxy_gl_version() < 45) {
    throw core::Error(where + ": OpenGL 4.5 core is required, the driver offers " +
                      std::to_string(epoxy_gl_version() / 10) + "." + std::to_string(epoxy_gl_version() % 10));
  }
}

std::string EglErrorText() {
  const EGLint e = eglGetError();
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "0x%04x", static_cast<unsigned>(e));
  return buffer;
}

class EglContext : public GlContext {
 public:
  EglContext() {
    if (!epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_platform_base")) {
      throw core::Error("headless OpenGL: libEGL lacks EGL_EXT_platform_base (install libegl1 and libegl-mesa0)");
    }
    std::string tried;
    if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless")) {
      display_ = eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
      if (display_ != EGL_NO_DISPLAY && !eglInitialize(display_, nullptr, nullptr)) display_ = EGL_NO_DISPLAY;
      tried += "surfaceless platform";
    }
    if (display_ == EGL_NO_DISPLAY && epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_platform_device")) {
      EGLDeviceEXT devices[8];
      EGLint count = 0;
      if (eglQueryDevicesEXT(8, devices, &count) && count > 0) {
        display_ = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[0], nullptr);
        if (display_ != EGL_NO_DISPLAY && !eglInitialize(display_, nullptr, nullptr)) display_ = EGL_NO_DISPLAY;
      }
      tried += tried.empty() ? "EGL devices" : " and EGL devices";
    }
    if (display_ == EGL_NO_DISPLAY) {
      throw core::Error("headless OpenGL: no EGL display (tried " +
                        (tried.empty()
                             ? std::string("nothing: neither "
                                           "EGL_MESA_platform_surfaceless nor EGL_EXT_platform_device is offered")
                             : tried) +
                        "; install libegl-mesa0 for Mesa's surfaceless platform)");
    }
    if (!eglBindAPI(EGL_OPENGL_API)) {
      throw core::Error("headless OpenGL: the EGL display has no desktop OpenGL API (error " + EglErrorText() + ")");
    }
    // Surface type 0: any config (the surfaceless platform offers pbuffer ones only).
    const EGLint config_attributes[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig config = nullptr;
    EGLint config_count = 0;
    if (!eglChooseConfig(display_, config_attributes, &config, 1, &config_count) || config_count < 1) {
      throw core::Error("headless OpenGL: no EGL config with desktop OpenGL (error " + EglErrorText() + ")");
    }
    const EGLint context_attributes[] = {
        EGL_CONTEXT_MAJOR_VERSION,           4,       EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
        EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    context_ = eglCreateContext(display_, config, EGL_NO_CONTEXT, context_attributes);
    if (context_ == EGL_NO_CONTEXT) {
      throw core::Error("headless OpenGL: the EGL driver cannot create an OpenGL 4.5 core context (error " +
                        EglErrorText() + ")");
    }
    // Surfaceless: the renderer draws into framebuffer objects only.
    if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_)) {
      throw core::Error("headless OpenGL: cannot make the context current without a surface (error " + EglErrorText() +
                        "; EGL_KHR_surfaceless_context missing?)");
    }
    ExpectGl45("headless OpenGL");
  }
  ~EglContext() override {
    if (display_ != EGL_NO_DISPLAY) {
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
      eglTerminate(display_);
    }
  }
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

 private:
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
};

std::string& GlfwLastError() {
  static std::string message;
  return message;
}

class GlfwContext : public GlContext {
 public:
  GlfwContext(int width, int height, const std::string& title) {
    const char* x11 = std::getenv("DISPLAY");
    const char* wayland = std::getenv("WAYLAND_DISPLAY");
    if ((x11 == nullptr || *x11 == '\0') && (wayland == nullptr || *wayland == '\0')) {
      throw core::Error(
          "window: no display (neither DISPLAY nor WAYLAND_DISPLAY is set); use `mesocap render` for "
          "headless output");
    }
    glfwSetErrorCallback([](int, const char* text) { GlfwLastError() = text; });
    if (!glfwInit()) throw core::Error("window: GLFW cannot initialise: " + GlfwLastError());
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (window_ == nullptr) {
      glfwTerminate();
      throw core::Error("window: GLFW cannot create a window with an OpenGL 4.5 core context: " + GlfwLastError());
    }
    glfwMakeContextCurrent(window_);
    ExpectGl45("window");
  }
  ~GlfwContext() override {
    glfwDestroyWindow(window_);
    glfwTerminate();
  }
  GlfwContext(const GlfwContext&) = delete;
  GlfwContext& operator=(const GlfwContext&) = delete;
  GLFWwindow* window() const override { return window_; }

 private:
  GLFWwindow* window_ = nullptr;
};

}  // namespace

std::unique_ptr<GlContext> GlContext::MakeHeadless() { return std::make_unique<EglContext>(); }

std::unique_ptr<GlContext> GlContext::MakeWindow(int width, int height, const std::string& title) {
  return std::make_unique<GlfwContext>(width, height, title);
}

std::string GlContext::Description() const {
  const auto text = [](GLenum name) {
    const auto* s = reinterpret_cast<const char*>(glGetString(name));
    return std::string(s != nullptr ? s : "?");
  };
  return text(GL_RENDERER) + " / OpenGL " + text(GL_VERSION);
}

}  // namespace mesocap::render
