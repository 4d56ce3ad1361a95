// `mesocap view SCENE`: the interactive viewer on the same renderer as
// `mesocap render` (GLFW window). Left drag orbits the camera, right drag
// moves the light around the scene, the wheel zooms; keys 1/2/3 pick BTF
// only / + silhouettes / + shadows, P toggles adaptive and fixed (+/-) peel
// passes, Esc quits. The title shows the frame time and passes.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "apps/mesocap/render_scene_option.h"
#include "core/angles.h"
#include "render/gl_context.h"
#include "render/peeling_renderer.h"

namespace mesocap {
namespace {

// Rotates `point` about `centre`: yaw about +z, then pitch about the
// horizontal axis, keeping the elevation inside (-89, 89) degrees.
Eigen::Vector3d Orbit(const Eigen::Vector3d& point, const Eigen::Vector3d& centre, double yaw, double pitch) {
  Eigen::Vector3d d = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * (point - centre);
  const double elevation = std::asin(std::clamp(d.normalized().z(), -1.0, 1.0));
  const double limit = core::RadiansFromDegrees(89.0);
  pitch = std::clamp(elevation + pitch, -limit, limit) - elevation;
  const Eigen::Vector3d axis = d.cross(Eigen::Vector3d::UnitZ()).normalized();
  if (axis.allFinite()) d = Eigen::AngleAxisd(-pitch, axis) * d;
  return centre + d;
}

void RunView(const RenderSceneOptions& o) {
  render::PeelingOptions peeling = o.Peeling();
  // The window first: without a display, say so before any material is built.
  const auto context = render::GlContext::MakeWindow(peeling.width, peeling.height, "mesocap view");
  render::RenderScene scene = render::ReadRenderScene(o.scene, ResolveRenderMaterial);
  GLFWwindow* window = context->window();
  spdlog::info("OpenGL: {}", context->Description());
  render::PeelingRenderer renderer(scene);
  const Eigen::Vector3d centre = scene.Bounds().first;
  double last_x = 0, last_y = 0;
  glfwGetCursorPos(window, &last_x, &last_y);
  int fixed_passes = 4;
  bool adaptive = peeling.passes == 0;
  while (!glfwWindowShouldClose(window)) {
    glfwPollEvents();
    if (glfwGetKey(window, GLFW_KEY_ESCAPE) == GLFW_PRESS) break;
    if (glfwGetKey(window, GLFW_KEY_1) == GLFW_PRESS) peeling.mode = render::RenderMode::kBtf;
    if (glfwGetKey(window, GLFW_KEY_2) == GLFW_PRESS) peeling.mode = render::RenderMode::kSilhouette;
    if (glfwGetKey(window, GLFW_KEY_3) == GLFW_PRESS) peeling.mode = render::RenderMode::kFull;
    if (glfwGetKey(window, GLFW_KEY_P) == GLFW_PRESS) adaptive = !adaptive;
    if (glfwGetKey(window, GLFW_KEY_EQUAL) == GLFW_PRESS) fixed_passes = std::min(fixed_passes + 1, 254);
    if (glfwGetKey(window, GLFW_KEY_MINUS) == GLFW_PRESS) fixed_passes = std::max(fixed_passes - 1, 1);
    peeling.passes = adaptive ? 0 : fixed_passes;
    double x = 0, y = 0;
    glfwGetCursorPos(window, &x, &y);
    const double yaw = -(x - last_x) * 0.01, pitch = (y - last_y) * 0.01;
    if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_LEFT) == GLFW_PRESS) {
      scene.camera.position = Orbit(scene.camera.position, scene.camera.look_at, yaw, pitch);
    }
    if (glfwGetMouseButton(window, GLFW_MOUSE_BUTTON_RIGHT) == GLFW_PRESS) {
      scene.light.position = Orbit(scene.light.position, centre, yaw, pitch);
    }
    last_x = x;
    last_y = y;
    int width = 0, height = 0;
    glfwGetFramebufferSize(window, &width, &height);
    if (width > 0 && height > 0) {
      peeling.width = width;
      peeling.height = height;
      const render::RenderResult frame = renderer.Draw(scene.camera, scene.light, peeling);
      renderer.Present(width, height);
      glfwSwapBuffers(window);
      const std::string title = std::string("mesocap view - ") + render::ToString(peeling.mode) + " - " +
                                std::to_string(frame.frame_ms).substr(0, 6) + " ms - passes " +
                                std::to_string(frame.passes) + "/" + std::to_string(frame.shadow_passes);
      glfwSetWindowTitle(window, title.c_str());
    }
  }
}

}  // namespace

void RegisterViewCommand(CLI::App& app) {
  auto o = std::make_shared<RenderSceneOptions>();
  CLI::App* sub = app.add_subcommand("view", HelpText("view"));
  AddRenderSceneOptions(sub, o.get());
  sub->callback([o] { RunView(*o); });
}

}  // namespace mesocap
