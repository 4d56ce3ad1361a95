// A capture through served GigE Vision cameras whose server dies mid-session:
// the Aravis backend reports the camera disconnected, the runner stops with
// the step it was on, and once the cameras are served again the backend
// reopens them and the resumed capture equals an uninterrupted one byte for
// byte. Runs in a network namespace of its own (scripts/in-network-namespace.sh).
#include <gtest/gtest.h>

#include <functional>

#include "acquisition/capture_plan.h"
#include "acquisition/capture_session_runner.h"
#include "drivers/aravis/aravis_camera.h"
#include "drivers/aravis/aravis_rig_backend.h"
#include "drivers/aravis/camera_discovery.h"
#include "formats/capture_session.h"
#include "sim/builtin_scenes.h"
#include "sim/camera_renderer.h"
#include "sim/served_cameras.h"
#include "sim/simulated_operator.h"
#include "sim/simulated_rig_backend.h"
#include "tests/common/no_leftovers.h"
#include "tests/common/normalized_tree.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;

// Lamps that call `at_switch_on` when the `n`-th lamp is switched on.
class LampsThatInterrupt : public drivers::LampBank {
 public:
  LampsThatInterrupt(std::unique_ptr<drivers::LampBank> lamps, int n, std::function<void()> at_switch_on)
      : lamps_(std::move(lamps)), n_(n), at_switch_on_(std::move(at_switch_on)) {}
  int lamp_count() const override { return lamps_->lamp_count(); }
  void SetLamp(int index, bool on) override {
    lamps_->SetLamp(index, on);
    if (on && ++switched_on_ == n_) at_switch_on_();
  }
  bool IsOn(int index) const override { return lamps_->IsOn(index); }

 private:
  std::unique_ptr<drivers::LampBank> lamps_;
  int n_;
  int switched_on_ = 0;
  std::function<void()> at_switch_on_;
};

// The simulated rig of one capture, its cameras served or not.
struct Capture {
  explicit Capture(const formats::RigDescription& rig)
      : scene(sim::MakeBuiltinScene("weave")),
        description(rig),
        renderer(*scene, description, {1}),
        backend(renderer, {}, 5, sim::SensorModel::kNoisy),
        rig_operator(backend.shared_state()) {}

  void CreateSession(const fs::path& dir) const {
    formats::SessionManifest manifest;
    manifest.rig = description.json;
    manifest.plan = MakeCapturePlan(description, {{"simulated_scene", "weave"}});
    formats::CreateCaptureSession(dir, manifest);
  }
  CaptureRunReport Run(const fs::path& dir, drivers::Rig& devices) {
    CaptureRunnerOptions options;
    options.show_progress = false;
    // Generous: a frame merely late on a loaded machine would be taken again
    // with fresh sensor noise, and the byte comparison would fail on timing.
    options.frame_timeout = std::chrono::milliseconds(5000);
    return RunCaptureSession(dir, devices, rig_operator, options);
  }
  // The rig with its cameras through the Aravis backend at `served`.
  drivers::Rig ServedRig(const sim::ServedCameras& served) {
    formats::RigDescription d = description;
    for (std::size_t i = 0; i < served.size(); ++i) {
      d.cameras[i].backend = "aravis";
      d.cameras[i].device = served.address(i).address;
    }
    drivers::Rig devices = drivers::BuildRig(d, {{"sim", &backend}, {"aravis", &aravis}});
    devices.description = description;
    return devices;
  }

  std::unique_ptr<sim::MesostructureScene> scene;
  formats::RigDescription description;
  sim::CameraRenderer renderer;
  sim::SimulatedRigBackend backend;
  drivers::aravis::AravisRigBackend aravis;
  sim::SimulatedOperator rig_operator;
};

TEST(ServedCameraCapture, KilledServerStopsTheCaptureAndResumeIsByteIdentical) {
  testing::TemporaryDirectory dir;
  const formats::RigDescription rig = formats::ParseRigDescription(testing::OneSweepRig(), dir / "rig.json");

  Capture reference(rig);
  reference.CreateSession(dir / "reference" / "S");
  drivers::Rig direct = drivers::BuildRig(rig, {{"sim", &reference.backend}});
  reference.Run(dir / "reference" / "S", direct);

  Capture capture(rig);
  capture.CreateSession(dir / "served" / "S");
  auto served = sim::ServeRigCameras(rig, capture.backend);
  drivers::Rig devices = capture.ServedRig(*served);
  // The server dies as the second BTF lamp goes on: mid-session, after
  // steps were journaled.
  devices.lamps = std::make_unique<LampsThatInterrupt>(std::move(devices.lamps), 2, [&] { served.reset(); });
  try {
    capture.Run(dir / "served" / "S", devices);
    ADD_FAILURE() << "the capture went on without its cameras";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera cam0 (127.0.0.1): disconnected"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("resume"), std::string::npos) << e.what();
  }
  ASSERT_EQ(served, nullptr);

  // The cameras come back; the backend reopens them by their addresses.
  served = sim::ServeRigCameras(rig, capture.backend);
  for (auto& camera : devices.cameras) static_cast<drivers::aravis::AravisCamera&>(*camera).Reopen();
  const CaptureRunReport resumed = capture.Run(dir / "served" / "S", devices);
  EXPECT_GT(resumed.steps_done_before, 0u);
  EXPECT_GT(resumed.steps_run, 0u);
  EXPECT_EQ(
      testing::Differences(testing::Normalized(dir / "reference" / "S"), testing::Normalized(dir / "served" / "S")),
      "");
}

// No process or socket outlives the tests (tests/common/no_leftovers.h),
// once Aravis has let go of its discovery sockets.
::testing::Environment* const kNoLeftovers =
    ::testing::AddGlobalTestEnvironment(new ::mesocap::testing::NoLeftovers(drivers::aravis::ReleaseDiscovery));

}  // namespace
}  // namespace mesocap::acquisition
