// `mesocap sim serve-cameras --rig R --scene S`: the simulated rig's cameras
// served as GigE Vision devices (sim/served_cameras.h) until SIGINT or
// SIGTERM, showing the scene with the stages, lamp and laser where the
// options put them. Any GenICam client can connect (arv-tool-0.8,
// arv-viewer-0.8, a rig description whose cameras are "aravis").
#include <signal.h>
#include <spdlog/spdlog.h>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "apps/mesocap/scene_option.h"
#include "core/angles.h"
#include "sim/camera_renderer.h"
#include "sim/mesostructure_scene.h"
#include "sim/served_cameras.h"
#include "sim/shipped_rigs.h"
#include "sim/simulated_rig_backend.h"

namespace mesocap {
namespace {

struct ServeCamerasOptions {
  sim::SceneSource scene;
  std::string rig = "tiny";
  double turntable_deg = 0.0;
  double arc_deg = 0.0;
  int lamp = 0;
  std::uint64_t seed = 1;
};

void RunServeCameras(const ServeCamerasOptions& o) {
  const formats::RigDescription rig = sim::LoadRig(o.rig);
  if (o.lamp >= static_cast<int>(rig.lamps.elevations_rad.size())) {
    throw core::Error("--lamp: rig " + rig.name + " has lamps 0 to " +
                      std::to_string(rig.lamps.elevations_rad.size() - 1));
  }
  const auto scene = sim::LoadScene(o.scene);
  sim::CameraRenderer renderer(*scene, rig, {});
  sim::SimulatedRigBackend backend(renderer, {}, o.seed);
  sim::SimulatedRigState& state = backend.state();
  state.turntable_rad = core::RadiansFromDegrees(o.turntable_deg);
  state.light_arc_rad = core::RadiansFromDegrees(o.arc_deg);
  state.lamps_on.assign(rig.lamps.elevations_rad.size(), false);
  state.lamps_on[o.lamp] = true;
  // Block the signals before the devices start their threads, so that only
  // sigwait below receives them.
  sigset_t stop;
  sigemptyset(&stop);
  sigaddset(&stop, SIGINT);
  sigaddset(&stop, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop, nullptr);
  const auto served = sim::ServeRigCameras(rig, backend);
  for (std::size_t i = 0; i < served->size(); ++i) {
    spdlog::info("camera {} served at {} (serial {})", rig.cameras[i].id, served->address(i).address,
                 served->address(i).serial);
  }
  spdlog::info("serving {} cameras of rig {} (scene {}); stop with Ctrl-C", served->size(), rig.name, scene->name());
  int signal = 0;
  sigwait(&stop, &signal);
  std::uint64_t frames = 0;
  for (std::size_t i = 0; i < served->size(); ++i) frames += served->frames_served(i);
  spdlog::info("stopped: {} frames served", frames);
}

}  // namespace

void RegisterServeCamerasCommand(CLI::App& app) {
  auto o = std::make_shared<ServeCamerasOptions>();
  CLI::App* group = GroupCommand(app, "sim", "The simulated rig's devices");
  CLI::App* sub = group->add_subcommand("serve-cameras", HelpText("sim_serve_cameras"));
  AddSceneOptions(sub, &o->scene);
  sub->add_option("--rig", o->rig, "shipped rig (tiny, small, paper) or a rig description file")->capture_default_str();
  sub->add_option("--turntable-deg", o->turntable_deg, "turntable angle")->check(InRange(-360, 360));
  sub->add_option("--arc-deg", o->arc_deg, "light arc angle")->check(InRange(-360, 360));
  sub->add_option("--lamp", o->lamp, "the lamp that is on")->check(InRange(0, 255))->capture_default_str();
  sub->callback([o] { RunServeCameras(*o); });
}

}  // namespace mesocap
