#include "sim/simulated_devices.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>

#include "core/angles.h"
#include "core/json_field_reader.h"
#include "drivers/device_error.h"
#include "drivers/rig.h"
#include "sim/fault_plan.h"
#include "sim/simulated_rig_backend.h"

namespace mesocap::sim {
namespace {

using std::chrono::milliseconds;
constexpr double kDeg = core::kRadiansPerDegree;
constexpr milliseconds kLong{600000};

std::filesystem::path RigFile(const std::string& name) {
  return std::filesystem::path(MESOCAP_SOURCE_DIR) / "sim" / "rigs" / (name + ".json");
}

formats::RigDescription Tiny() { return formats::ReadRigDescription(RigFile("tiny")); }

// Tiny with 8 x 8 sensors, for tests that grab thousands of frames.
formats::RigDescription TinyWithSmallSensors() {
  auto rig = Tiny();
  for (auto& c : rig.cameras) c.width = c.height = 8;
  return rig;
}

// Test double: an image whose channels carry the state, so a test sees what
// reached the renderer. Channel 0: turntable angle / 10; channel 1: 0.25 per
// lamp on; channel 2: `base` + x / 1000 (to see the region's crop). A mono
// readout gets their mean.
class StateEchoRenderer : public FrameRenderer {
 public:
  core::Image Render(const SimulatedRigState& state, int camera, int channels) override {
    ++renders;
    last_camera = camera;
    last_clock_s = state.clock_s;
    const auto& c = rig.cameras.at(camera);
    core::Image image(c.width, c.height, 3);
    int lamps = 0;
    for (bool on : state.lamps_on) lamps += on ? 1 : 0;
    for (int y = 0; y < c.height; ++y) {
      for (int x = 0; x < c.width; ++x) {
        image.at(x, y, 0) = static_cast<float>(state.turntable_rad / 10.0);
        image.at(x, y, 1) = 0.25f * static_cast<float>(lamps);
        image.at(x, y, 2) = base + static_cast<float>(x) / 1000.0f;
      }
    }
    return channels == 1 ? core::ChannelMean(image) : image;
  }

  formats::RigDescription rig;
  float base = 0.0f;
  int renders = 0;
  int last_camera = -1;
  double last_clock_s = -1.0;
};

FaultPlan Plan(FaultKind kind, std::vector<std::uint64_t> at, std::string device = "") {
  FaultRule rule;
  rule.kind = kind;
  rule.at = std::move(at);
  rule.device = std::move(device);
  return FaultPlan{{rule}};
}

FaultPlan RatePlan(FaultKind kind, double rate, std::string device = "") {
  FaultRule rule;
  rule.kind = kind;
  rule.rate = rate;
  rule.device = std::move(device);
  return FaultPlan{{rule}};
}

// One simulated rig: the backend, its renderer and the devices of `rig`.
struct SimRig {
  explicit SimRig(formats::RigDescription description, FaultPlan faults = {}, std::uint64_t seed = 1)
      : backend(renderer, std::move(faults), seed, SensorModel::kIdeal),
        rig(drivers::BuildRig(description, {{"sim", &backend}})) {
    renderer.rig = std::move(description);
  }

  SimulatedRigState& state() { return backend.state(); }
  drivers::Camera& camera(int i = 0) { return *rig.cameras.at(i); }

  StateEchoRenderer renderer;
  SimulatedRigBackend backend;
  drivers::Rig rig;
};

// ---------------------------------------------------------------- stages

TEST(SimulatedStage, ReachesTargetsInAngleOverSpeed) {
  SimRig sim(Tiny());  // turntable 30 deg/s, light arc 20 deg/s
  auto& table = *sim.rig.turntable;
  EXPECT_EQ(table.id(), "turntable");
  EXPECT_FALSE(table.IsHomed());
  table.Home();  // from 0: only the approach to the switch
  EXPECT_TRUE(table.IsHomed());
  EXPECT_NEAR(sim.state().clock_s, SimulatedRotaryStage::kHomingApproachS, 1e-12);

  const double t0 = sim.state().clock_s;
  table.MoveTo(90 * kDeg);
  EXPECT_TRUE(table.IsMoving());
  table.WaitUntilStopped(milliseconds(3001));
  EXPECT_FALSE(table.IsMoving());
  EXPECT_NEAR(sim.state().clock_s - t0, 3.0, 1e-12);
  EXPECT_NEAR(table.Position(), 90 * kDeg, 1e-12);
  EXPECT_NEAR(sim.state().turntable_rad, 90 * kDeg, 1e-12);
  EXPECT_EQ(sim.state().light_arc_rad, 0.0);

  // Homing from 90 degrees: 3 s back plus the approach.
  const double t1 = sim.state().clock_s;
  table.Home();
  EXPECT_NEAR(sim.state().clock_s - t1, 3.0 + SimulatedRotaryStage::kHomingApproachS, 1e-12);
  EXPECT_EQ(table.Position(), 0.0);
}

TEST(SimulatedStage, TakesTheShorterWayAndWraps) {
  SimRig sim(Tiny());
  auto& table = *sim.rig.turntable;
  table.Home();
  double t = sim.state().clock_s;
  table.MoveTo(350 * kDeg);  // 10 degrees backwards, not 350 forwards
  table.WaitUntilStopped(milliseconds(1000));
  EXPECT_NEAR(sim.state().clock_s - t, 10.0 / 30.0, 1e-12);
  EXPECT_NEAR(table.Position(), 350 * kDeg, 1e-12);

  t = sim.state().clock_s;
  table.MoveTo(-90 * kDeg);  // = 270 degrees, 80 degrees back
  table.WaitUntilStopped(kLong);
  EXPECT_NEAR(sim.state().clock_s - t, 80.0 / 30.0, 1e-12);
  EXPECT_NEAR(table.Position(), 270 * kDeg, 1e-12);

  t = sim.state().clock_s;
  table.MoveTo(2 * std::numbers::pi + 10 * kDeg);  // = 10 degrees, 100 forwards across 0
  table.WaitUntilStopped(kLong);
  EXPECT_NEAR(sim.state().clock_s - t, 100.0 / 30.0, 1e-12);
  EXPECT_NEAR(table.Position(), 10 * kDeg, 1e-12);
  EXPECT_NEAR(sim.state().turntable_rad, 10 * kDeg, 1e-12);
}

TEST(SimulatedStage, StagesMovedTogetherFinishTogether) {
  SimRig sim(Tiny());
  sim.rig.turntable->Home();
  sim.rig.light_arc->Home();
  EXPECT_EQ(sim.rig.light_arc->id(), "light_arc");
  const double t = sim.state().clock_s;
  sim.rig.turntable->MoveTo(90 * kDeg);   // 3 s
  sim.rig.light_arc->MoveTo(180 * kDeg);  // 9 s
  sim.rig.light_arc->WaitUntilStopped(kLong);
  sim.rig.turntable->WaitUntilStopped(kLong);
  EXPECT_NEAR(sim.state().clock_s - t, 9.0, 1e-12);
  EXPECT_NEAR(sim.state().turntable_rad, 90 * kDeg, 1e-12);
  EXPECT_NEAR(sim.state().light_arc_rad, 180 * kDeg, 1e-12);
}

TEST(SimulatedStage, TimeoutLeavesTheStageWhereItGotTo) {
  SimRig sim(Tiny());
  auto& table = *sim.rig.turntable;
  table.Home();
  const double t = sim.state().clock_s;
  table.MoveTo(180 * kDeg);  // 6 s
  EXPECT_THROW(table.WaitUntilStopped(milliseconds(2000)), drivers::TimeoutError);
  EXPECT_NEAR(sim.state().clock_s - t, 2.0, 1e-12);
  EXPECT_TRUE(table.IsMoving());
  EXPECT_NEAR(table.Position(), 60 * kDeg, 1e-12);
  EXPECT_NEAR(sim.state().turntable_rad, 60 * kDeg, 1e-12);
  table.WaitUntilStopped(milliseconds(4000));  // the rest of the move
  EXPECT_NEAR(sim.state().clock_s - t, 6.0, 1e-12);
  EXPECT_NEAR(table.Position(), 180 * kDeg, 1e-12);
}

TEST(SimulatedStage, MoveBeforeHomeIsRefused) {
  SimRig sim(Tiny());
  EXPECT_THROW(sim.rig.turntable->MoveTo(1.0), drivers::DeviceError);
  sim.rig.turntable->Home();
  EXPECT_THROW(sim.rig.turntable->MoveTo(std::nan("")), drivers::DeviceError);
  EXPECT_NO_THROW(sim.rig.turntable->WaitUntilStopped(milliseconds(0)));  // nothing to wait for
}

// ---------------------------------------------------------------- lamps, laser

TEST(SimulatedLamps, SwitchTheStateAndCheckTheIndex) {
  SimRig sim(Tiny());
  auto& lamps = *sim.rig.lamps;
  ASSERT_EQ(lamps.lamp_count(), 2);
  ASSERT_EQ(sim.state().lamps_on.size(), 2u);
  lamps.SetLamp(1, true);
  EXPECT_TRUE(lamps.IsOn(1));
  EXPECT_FALSE(lamps.IsOn(0));
  EXPECT_EQ(sim.state().lamps_on, (std::vector<bool>{false, true}));
  lamps.AllOff();
  EXPECT_EQ(sim.state().lamps_on, (std::vector<bool>{false, false}));
  EXPECT_THROW(lamps.SetLamp(2, true), drivers::DeviceError);
  EXPECT_THROW(lamps.SetLamp(-1, false), drivers::DeviceError);
  EXPECT_THROW(lamps.IsOn(2), drivers::DeviceError);
}

TEST(SimulatedLaser, TiltTakesTimeAndMountsAreChecked) {
  SimRig sim(Tiny());
  auto& laser = *sim.rig.laser;
  laser.SetEnabled(true);
  EXPECT_TRUE(laser.IsEnabled());
  EXPECT_TRUE(sim.state().laser_on);

  double t = sim.state().clock_s;
  laser.SetTilt(15 * kDeg, milliseconds(1000));  // 15 deg at 30 deg/s
  EXPECT_NEAR(sim.state().clock_s - t, 0.5, 1e-12);
  EXPECT_NEAR(laser.Tilt(), 15 * kDeg, 1e-12);
  EXPECT_NEAR(sim.state().laser_tilt_rad, 15 * kDeg, 1e-12);

  t = sim.state().clock_s;
  EXPECT_THROW(laser.SetTilt(-45 * kDeg, milliseconds(1000)), drivers::TimeoutError);  // needs 2 s
  EXPECT_NEAR(sim.state().clock_s - t, 1.0, 1e-12);
  EXPECT_NEAR(laser.Tilt(), -15 * kDeg, 1e-12);  // where it got to
  EXPECT_THROW(laser.SetTilt(46 * kDeg, kLong), drivers::DeviceError);
  EXPECT_THROW(laser.SetTilt(std::nan(""), kLong), drivers::DeviceError);

  ASSERT_EQ(laser.mount_count(), 2);
  laser.SetMount(1);
  EXPECT_EQ(laser.mount(), 1);
  EXPECT_EQ(sim.state().laser_mount, 1);
  EXPECT_THROW(laser.SetMount(2), drivers::DeviceError);
  EXPECT_THROW(laser.SetMount(-1), drivers::DeviceError);
  EXPECT_EQ(laser.mount(), 1);
}

// ---------------------------------------------------------------- camera

TEST(SimulatedCamera, InfoAndSettersFollowTheDescription) {
  SimRig sim(Tiny());
  auto& cam = sim.camera(1);
  const auto info = cam.info();
  EXPECT_EQ(info.id, "cam1");
  EXPECT_EQ(info.model, "mesocap simulated camera");
  EXPECT_EQ(info.sensor_width, 128);
  EXPECT_EQ(info.sensor_height, 96);
  EXPECT_EQ(info.bit_depth, 12);
  EXPECT_EQ(info.channels, 3);
  EXPECT_EQ(cam.settings().exposure_us, 20000.0);

  EXPECT_THROW(cam.SetExposure(0.5), drivers::DeviceError);
  EXPECT_THROW(cam.SetExposure(10.5e6), drivers::DeviceError);
  EXPECT_THROW(cam.SetExposure(std::nan("")), drivers::DeviceError);
  cam.SetExposure(1.0);
  cam.SetExposure(10e6);
  EXPECT_EQ(cam.settings().exposure_us, 10e6);
  EXPECT_THROW(cam.SetGain(-0.1), drivers::DeviceError);
  EXPECT_THROW(cam.SetGain(48.5), drivers::DeviceError);
  cam.SetGain(12.0);
  EXPECT_EQ(cam.settings().gain_db, 12.0);

  EXPECT_THROW(cam.SetRegion({100, 0, 29, 10}), drivers::DeviceError);  // 100 + 29 > 128
  EXPECT_THROW(cam.SetRegion({0, 90, 10, 7}), drivers::DeviceError);
  EXPECT_THROW(cam.SetRegion({-1, 0, 10, 10}), drivers::DeviceError);
  EXPECT_THROW(cam.SetRegion({5, 0, 0, 10}), drivers::DeviceError);  // full width from x 5
  cam.SetRegion({100, 0, 28, 96});
  EXPECT_EQ(cam.settings().region.x, 100);
  try {
    cam.SetGain(60);
    FAIL();
  } catch (const drivers::DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("camera cam1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("[0, 48] dB"), std::string::npos) << e.what();
  }
}

TEST(SimulatedCamera, GrabRendersTheCurrentState) {
  SimRig sim(Tiny());
  auto& cam = sim.camera(1);
  sim.rig.turntable->Home();
  sim.rig.turntable->MoveTo(90 * kDeg);
  sim.rig.turntable->WaitUntilStopped(kLong);
  sim.rig.lamps->SetLamp(0, true);

  const double t = sim.state().clock_s;
  cam.Trigger();
  const drivers::Frame f0 = cam.Grab(milliseconds(100));
  EXPECT_EQ(sim.renderer.last_camera, 1);
  EXPECT_EQ(f0.sequence, 0u);
  EXPECT_EQ(f0.timestamp_s, t);
  EXPECT_NEAR(sim.state().clock_s - t, 0.02, 1e-12);  // one 20 ms exposure
  EXPECT_EQ(f0.bit_depth, 12);
  EXPECT_EQ(f0.saturated_pixels, 0u);
  ASSERT_EQ(f0.image.width(), 128);
  ASSERT_EQ(f0.image.height(), 96);
  EXPECT_NEAR(f0.image.at(5, 7, 0), 90 * kDeg / 10, 1e-6);
  EXPECT_NEAR(f0.image.at(5, 7, 1), 0.25, 1e-6);

  sim.rig.lamps->SetLamp(1, true);
  sim.rig.turntable->MoveTo(180 * kDeg);
  sim.rig.turntable->WaitUntilStopped(kLong);
  cam.Trigger();
  const drivers::Frame f1 = cam.Grab(milliseconds(100));
  EXPECT_EQ(f1.sequence, 1u);
  EXPECT_GT(f1.timestamp_s, f0.timestamp_s);
  EXPECT_NEAR(f1.image.at(0, 0, 0), 180 * kDeg / 10, 1e-6);
  EXPECT_NEAR(f1.image.at(0, 0, 1), 0.5, 1e-6);
  EXPECT_EQ(sim.renderer.renders, 2);
}

TEST(SimulatedCamera, SoftwareTriggerWaitsFreeRunStreams) {
  SimRig sim(Tiny());
  auto& cam = sim.camera();
  const double t = sim.state().clock_s;
  EXPECT_THROW(cam.Grab(milliseconds(250)), drivers::TimeoutError);  // no Trigger()
  EXPECT_NEAR(sim.state().clock_s - t, 0.25, 1e-12);
  EXPECT_EQ(sim.renderer.renders, 0);
  cam.SetTrigger(drivers::TriggerMode::kFreeRun);
  EXPECT_EQ(cam.Grab(milliseconds(100)).sequence, 0u);
  EXPECT_EQ(cam.Grab(milliseconds(100)).sequence, 1u);
  EXPECT_EQ(cam.Grab(milliseconds(100)).sequence, 2u);
}

TEST(SimulatedCamera, ExposureGainAndRegionShapeTheSignal) {
  SimRig sim(Tiny());
  auto& cam = sim.camera();
  cam.SetTrigger(drivers::TriggerMode::kFreeRun);
  sim.renderer.base = 0.25f;  // channel 2: 0.25 + x / 1000 at the description's 20 ms

  cam.SetExposure(40000);  // twice the description's exposure
  drivers::Frame f = cam.Grab(milliseconds(100));
  EXPECT_NEAR(f.image.at(0, 0, 2), 0.5, 1e-6);
  EXPECT_NEAR(f.image.at(10, 0, 2), 2 * 0.26, 1e-6);
  EXPECT_EQ(f.settings.exposure_us, 40000.0);
  EXPECT_EQ(f.saturated_pixels, 0u);

  cam.SetGain(20.0);  // x10 of amplitude: all at the top
  f = cam.Grab(milliseconds(100));
  EXPECT_EQ(f.image.at(0, 0, 2), 1.0f);
  EXPECT_EQ(f.image.at(127, 95, 2), 1.0f);
  EXPECT_EQ(f.saturated_pixels, 128u * 96u);
  EXPECT_EQ(f.settings.gain_db, 20.0);

  cam.SetExposure(2000);  // a tenth of the exposure undoes the gain
  f = cam.Grab(milliseconds(100));
  EXPECT_NEAR(f.image.at(0, 0, 2), 0.25, 1e-6);
  EXPECT_NEAR(f.image.at(10, 0, 2), 0.26, 1e-6);
  EXPECT_EQ(f.saturated_pixels, 0u);

  cam.SetGain(0.0);
  cam.SetExposure(20000);
  sim.renderer.base = 0.9905f;  // x >= 10 saturates
  cam.SetRegion({4, 10, 20, 30});
  f = cam.Grab(milliseconds(100));
  ASSERT_EQ(f.image.width(), 20);
  ASSERT_EQ(f.image.height(), 30);
  EXPECT_NEAR(f.image.at(0, 0, 2), 0.9905 + 4 / 1000.0, 1e-6);  // sensor x 4
  EXPECT_EQ(f.saturated_pixels, 30u * (20u - 6u));              // sensor x 10..23

  // Mono: one value a pixel, the mean of the channels, cut and scaled as RGB.
  sim.renderer.base = 0.25f;
  sim.state().turntable_rad = 1.0;  // channel 0: 0.1; no lamp on: channel 1 is 0
  cam.SetExposure(40000);
  cam.SetPixelFormat(drivers::PixelFormat::kMono);
  EXPECT_EQ(cam.settings().pixel_format, drivers::PixelFormat::kMono);
  f = cam.Grab(milliseconds(100));
  ASSERT_EQ(f.image.channels(), 1);
  ASSERT_EQ(f.image.width(), 20);
  EXPECT_NEAR(f.image.at(0, 0), 2 * (0.1 + 0.0 + 0.25 + 4 / 1000.0) / 3, 1e-6);
  EXPECT_EQ(f.settings.pixel_format, drivers::PixelFormat::kMono);
  cam.SetPixelFormat(drivers::PixelFormat::kNative);
  EXPECT_EQ(cam.Grab(milliseconds(100)).image.channels(), 3);
}

// ---------------------------------------------------------------- faults at a step

TEST(SimulatedFaults, DroppedFrameSkipsItsSequenceNumber) {
  SimRig sim(Tiny(), Plan(FaultKind::kCameraDropFrame, {3}, "cam0"));
  auto& cam = sim.camera(0);
  cam.SetTrigger(drivers::TriggerMode::kFreeRun);
  std::vector<std::uint64_t> seq;
  for (int i = 0; i < 4; ++i) seq.push_back(cam.Grab(milliseconds(100)).sequence);
  EXPECT_EQ(seq, (std::vector<std::uint64_t>{0, 1, 3, 4}));
  EXPECT_EQ(sim.renderer.renders, 4);  // the lost frame is not delivered
  // The other camera is not named, and drops nothing.
  sim.camera(1).SetTrigger(drivers::TriggerMode::kFreeRun);
  for (std::uint64_t i = 0; i < 4; ++i) EXPECT_EQ(sim.camera(1).Grab(milliseconds(100)).sequence, i);
}

TEST(SimulatedFaults, CameraTimeoutLosesTheFrame) {
  SimRig sim(Tiny(), Plan(FaultKind::kCameraTimeout, {2}));
  auto& cam = sim.camera();
  cam.Trigger();
  EXPECT_EQ(cam.Grab(milliseconds(100)).sequence, 0u);
  cam.Trigger();
  const double t = sim.state().clock_s;
  EXPECT_THROW(cam.Grab(milliseconds(500)), drivers::TimeoutError);
  EXPECT_NEAR(sim.state().clock_s - t, 0.5, 1e-12);
  cam.Trigger();
  EXPECT_EQ(cam.Grab(milliseconds(100)).sequence, 2u);  // a retry works
}

TEST(SimulatedFaults, DisconnectIsForGood) {
  SimRig sim(Tiny(), Plan(FaultKind::kCameraDisconnect, {4}, "cam1"));
  auto& cam = sim.camera(1);
  cam.SetExposure(1000);                                    // call 1
  cam.Trigger();                                            // 2
  cam.Grab(milliseconds(100));                              // 3
  EXPECT_THROW(cam.Trigger(), drivers::DisconnectedError);  // 4
  EXPECT_THROW(cam.SetGain(1.0), drivers::DisconnectedError);
  EXPECT_THROW(cam.Grab(milliseconds(100)), drivers::DisconnectedError);
  EXPECT_THROW(cam.SetTrigger(drivers::TriggerMode::kFreeRun), drivers::DisconnectedError);
  EXPECT_EQ(cam.info().id, "cam1");  // what the driver knew stays readable
  sim.camera(0).Trigger();
  EXPECT_NO_THROW(sim.camera(0).Grab(milliseconds(100)));
}

TEST(SimulatedFaults, StallUnhomesTheStageAtAnUnknownPosition) {
  SimRig sim(Tiny(), Plan(FaultKind::kStageStall, {2}, "turntable"));  // move 1 is Home
  auto& table = *sim.rig.turntable;
  table.Home();
  const double t = sim.state().clock_s;
  table.MoveTo(180 * kDeg);
  EXPECT_THROW(table.WaitUntilStopped(kLong), drivers::StallError);
  EXPECT_FALSE(table.IsHomed());
  EXPECT_FALSE(table.IsMoving());
  const double stood = sim.state().turntable_rad;
  EXPECT_GE(stood, 0.0);
  EXPECT_LT(stood, 180 * kDeg);                                     // it stopped part way
  EXPECT_NEAR(sim.state().clock_s - t, stood / (30 * kDeg), 1e-9);  // and when it stopped
  EXPECT_NEAR(table.Position(), 180 * kDeg, 1e-12);                 // its controller counted every step
  EXPECT_THROW(table.MoveTo(0.5), drivers::DeviceError);
  table.Home();
  EXPECT_EQ(sim.state().turntable_rad, 0.0);
  table.MoveTo(180 * kDeg);
  table.WaitUntilStopped(kLong);
  EXPECT_NEAR(sim.state().turntable_rad, 180 * kDeg, 1e-12);

  // The light arc counts its own moves and was not named.
  sim.rig.light_arc->Home();
  sim.rig.light_arc->MoveTo(1.0);
  EXPECT_NO_THROW(sim.rig.light_arc->WaitUntilStopped(kLong));
}

TEST(SimulatedFaults, StageTimeoutIsRetryable) {
  SimRig sim(Tiny(), Plan(FaultKind::kStageTimeout, {2}, "light_arc"));
  auto& arc = *sim.rig.light_arc;
  arc.Home();
  const double t = sim.state().clock_s;
  arc.MoveTo(20 * kDeg);  // 1 s
  EXPECT_THROW(arc.WaitUntilStopped(milliseconds(3000)), drivers::TimeoutError);
  EXPECT_NEAR(sim.state().clock_s - t, 3.0, 1e-12);
  EXPECT_TRUE(arc.IsHomed());
  arc.WaitUntilStopped(milliseconds(3000));
  EXPECT_NEAR(arc.Position(), 20 * kDeg, 1e-12);
  EXPECT_NEAR(sim.state().light_arc_rad, 20 * kDeg, 1e-12);
}

TEST(SimulatedFaults, HomingCanFailToo) {
  SimRig timeout(Tiny(), Plan(FaultKind::kStageTimeout, {1}));
  EXPECT_THROW(timeout.rig.turntable->Home(), drivers::TimeoutError);
  EXPECT_FALSE(timeout.rig.turntable->IsHomed());
  timeout.rig.turntable->Home();
  EXPECT_TRUE(timeout.rig.turntable->IsHomed());

  SimRig stall(Tiny(), Plan(FaultKind::kStageStall, {1}));
  EXPECT_THROW(stall.rig.light_arc->Home(), drivers::StallError);
  EXPECT_FALSE(stall.rig.light_arc->IsHomed());
  stall.rig.light_arc->Home();
  EXPECT_TRUE(stall.rig.light_arc->IsHomed());
}

TEST(SimulatedFaults, LampBurnsOutAndStaysDead) {
  SimRig sim(Tiny(), Plan(FaultKind::kLampFailure, {2}, LampDeviceId(1)));
  auto& lamps = *sim.rig.lamps;
  lamps.SetLamp(1, true);  // switch-on 1
  lamps.SetLamp(1, true);  // already on: no switching
  lamps.SetLamp(1, false);
  EXPECT_THROW(lamps.SetLamp(1, true), drivers::LampFailureError);  // switch-on 2
  EXPECT_FALSE(lamps.IsOn(1));
  EXPECT_FALSE(sim.state().lamps_on[1]);
  EXPECT_THROW(lamps.SetLamp(1, true), drivers::LampFailureError);
  EXPECT_NO_THROW(lamps.SetLamp(1, false));
  for (int i = 0; i < 5; ++i) {
    lamps.SetLamp(0, true);
    lamps.SetLamp(0, false);
  }
}

// ---------------------------------------------------------------- faults at a rate

TEST(SimulatedFaults, RatesHoldOverManyOperations) {
  for (FaultKind kind : kAllFaultKinds) {
    FaultSchedule schedule(RatePlan(kind, 0.1), kind, "dev", 7);
    int fired = 0;
    for (int i = 0; i < 10000; ++i) fired += schedule.Fires() ? 1 : 0;
    EXPECT_NEAR(fired, 1000, 100) << ToString(kind);
    EXPECT_EQ(schedule.operations(), 10000u);
  }
}

TEST(SimulatedFaults, DropRateThroughTheCamera) {
  SimRig sim(TinyWithSmallSensors(), RatePlan(FaultKind::kCameraDropFrame, 0.1), 3);
  auto& cam = sim.camera();
  cam.SetTrigger(drivers::TriggerMode::kFreeRun);
  std::uint64_t last = 0;
  int delivered = 0;
  while (last < 9999) {
    last = cam.Grab(milliseconds(1000)).sequence;
    ++delivered;
  }
  const double exposures = static_cast<double>(last + 1);  // 10,000 or a few more
  EXPECT_LT(exposures, 10010);
  EXPECT_NEAR(exposures - delivered, 0.1 * exposures, 100);  // a tenth were lost
}

TEST(SimulatedFaults, TimeoutAndStallRatesThroughTheDevices) {
  SimRig sim(TinyWithSmallSensors(),
             FaultPlan{{FaultRule{FaultKind::kCameraTimeout, "", 0.1, {}},
                        FaultRule{FaultKind::kStageStall, "turntable", 0.1, {}}}},
             5);
  auto& cam = sim.camera();
  int timeouts = 0;
  for (int i = 0; i < 10000; ++i) {
    cam.Trigger();
    try {
      cam.Grab(milliseconds(100));
    } catch (const drivers::TimeoutError&) {
      ++timeouts;
    }
  }
  EXPECT_NEAR(timeouts, 1000, 100);

  auto& table = *sim.rig.turntable;
  int moves = 0;
  int stalls = 0;
  while (moves < 10000) {
    if (!table.IsHomed()) {
      ++moves;
      try {
        table.Home();
      } catch (const drivers::StallError&) {
        ++stalls;
      }
      continue;
    }
    ++moves;
    table.MoveTo((moves % 4) * 90 * kDeg);
    try {
      table.WaitUntilStopped(kLong);
    } catch (const drivers::StallError&) {
      ++stalls;
    }
  }
  EXPECT_NEAR(stalls, 1000, 100);
}

// ---------------------------------------------------------------- seeds

std::vector<std::uint64_t> Sequences(SimRig& sim, int camera, int frames) {
  std::vector<std::uint64_t> out;
  for (int i = 0; i < frames; ++i) out.push_back(sim.camera(camera).Grab(milliseconds(1000)).sequence);
  return out;
}

TEST(SimulatedFaults, ASeedRepeatsWhateverTheOrderOfUse) {
  const FaultPlan drops = RatePlan(FaultKind::kCameraDropFrame, 0.3);
  SimRig a(TinyWithSmallSensors(), drops, 42);
  SimRig b(TinyWithSmallSensors(), drops, 42);
  SimRig c(TinyWithSmallSensors(), drops, 43);
  for (SimRig* s : {&a, &b, &c}) {
    for (int i = 0; i < 2; ++i) s->camera(i).SetTrigger(drivers::TriggerMode::kFreeRun);
  }
  // a: cam0 then cam1; b: cam1 then cam0, interleaved with lamp and stage use.
  const auto a0 = Sequences(a, 0, 50);
  const auto a1 = Sequences(a, 1, 50);
  b.rig.turntable->Home();
  b.rig.lamps->SetLamp(0, true);
  const auto b1 = Sequences(b, 1, 50);
  const auto b0 = Sequences(b, 0, 50);
  EXPECT_EQ(a0, b0);
  EXPECT_EQ(a1, b1);
  EXPECT_NE(a0, a1);  // each camera draws its own stream
  EXPECT_NE(a0, Sequences(c, 0, 50));
  EXPECT_NE(FaultStreamSeed(42, "cam0", FaultKind::kCameraDropFrame),
            FaultStreamSeed(42, "cam0", FaultKind::kCameraTimeout));
}

// ---------------------------------------------------------------- the rig

TEST(SimulatedRigBackend, BuildsTheWholeTinyRig) {
  StateEchoRenderer renderer;
  renderer.rig = Tiny();
  drivers::Rig rig = [&] {
    // The backend goes out of scope; the devices share its state.
    SimulatedRigBackend backend(renderer, {}, 9);
    EXPECT_EQ(backend.name(), "sim");
    return drivers::BuildRig(formats::ReadRigDescription(RigFile("tiny")), {{"sim", &backend}});
  }();
  ASSERT_EQ(rig.cameras.size(), 2u);
  EXPECT_EQ(rig.cameras[0]->info().id, "cam0");
  EXPECT_EQ(rig.cameras[1]->info().id, "cam1");
  EXPECT_EQ(rig.turntable->id(), "turntable");
  EXPECT_EQ(rig.light_arc->id(), "light_arc");
  EXPECT_EQ(rig.lamps->lamp_count(), 2);
  EXPECT_EQ(rig.laser->mount_count(), 2);
  rig.turntable->Home();
  rig.turntable->MoveTo(90 * kDeg);
  rig.turntable->WaitUntilStopped(kLong);
  rig.cameras[0]->Trigger();
  const auto frame = rig.cameras[0]->Grab(milliseconds(100));
  EXPECT_EQ(renderer.last_camera, 0);
  // By default the cameras are noisy: channel 0 carries the signal 90 deg /
  // 10 everywhere; its pixels scatter by the shot noise (sqrt(electrons) of
  // the full well) and average to the signal.
  const double signal = 90 * kDeg / 10;
  const auto& camera = renderer.rig.cameras[0];
  const double sigma = std::sqrt(signal * camera.full_well_electrons) / camera.full_well_electrons;
  double sum = 0.0, sum2 = 0.0;
  const int n = frame.image.width() * frame.image.height();
  for (int y = 0; y < frame.image.height(); ++y) {
    for (int x = 0; x < frame.image.width(); ++x) {
      sum += frame.image.at(x, y, 0);
      sum2 += frame.image.at(x, y, 0) * frame.image.at(x, y, 0);
    }
  }
  const double mean = sum / n;
  EXPECT_NEAR(mean, signal, 5 * sigma / std::sqrt(n));
  EXPECT_NEAR(std::sqrt(sum2 / n - mean * mean), sigma, 0.1 * sigma);
}

TEST(SimulatedRigBackend, RejectsFaultsForDevicesTheRigLacks) {
  StateEchoRenderer renderer;
  const auto tiny = Tiny();
  SimulatedRigBackend no_camera(renderer, Plan(FaultKind::kCameraTimeout, {1}, "cam7"));
  EXPECT_THROW(drivers::BuildRig(tiny, {{"sim", &no_camera}}), core::Error);
  SimulatedRigBackend no_lamp(renderer, Plan(FaultKind::kLampFailure, {1}, LampDeviceId(2)));
  EXPECT_THROW(drivers::BuildRig(tiny, {{"sim", &no_lamp}}), core::Error);
  FaultPlan both;
  both.rules.push_back(FaultRule{FaultKind::kLampFailure, "", 0.5, {3}});
  EXPECT_THROW({ SimulatedRigBackend bad(renderer, both); }, core::Error);
  EXPECT_NE(both.Check().find("lamp_failure"), std::string::npos) << both.Check();
  EXPECT_THROW({ SimulatedRigBackend bad(renderer, RatePlan(FaultKind::kStageStall, 1.5)); }, core::Error);
}

// ---------------------------------------------------------------- the JSON form

std::string FieldOf(const nlohmann::json& faults) {
  try {
    ParseFaultPlan(faults, "rig.json", "faults");
  } catch (const core::FormatError& e) {
    return e.field();
  }
  return "no error";
}

TEST(FaultPlanJson, ParsesRulesAndNamesTheFieldItRejects) {
  const auto plan = ParseFaultPlan(nlohmann::json::parse(R"({
      "camera_drop_frame": {"rate": 0.01},
      "stage_stall": {"device": "turntable", "at": [3, 1]},
      "lamp_failure": [{"device": 1, "at": [2]}, {"rate": 0.001}]})"),
                                   "rig.json", "faults");
  ASSERT_EQ(plan.rules.size(), 4u);
  EXPECT_EQ(plan.rules[0].kind, FaultKind::kCameraDropFrame);
  EXPECT_EQ(plan.rules[0].rate, 0.01);
  EXPECT_EQ(plan.rules[1].kind, FaultKind::kStageStall);
  EXPECT_EQ(plan.rules[1].device, "turntable");
  EXPECT_EQ(plan.rules[1].at, (std::vector<std::uint64_t>{3, 1}));
  EXPECT_EQ(plan.rules[2].device, "1");
  EXPECT_EQ(plan.rules[3].rate, 0.001);
  EXPECT_EQ(plan.Check(Tiny()), "");

  using nlohmann::json;
  EXPECT_EQ(FieldOf(json::parse(R"({"camera_explode": {"rate": 0.1}})")), "faults.camera_explode");
  EXPECT_EQ(FieldOf(json::parse(R"({"camera_timeout": {"rate": 1.5}})")), "faults.camera_timeout.rate");
  EXPECT_EQ(FieldOf(json::parse(R"({"camera_timeout": {"rate": 0.1, "at": [1]}})")), "faults.camera_timeout");
  EXPECT_EQ(FieldOf(json::parse(R"({"camera_timeout": {}})")), "faults.camera_timeout");
  EXPECT_EQ(FieldOf(json::parse(R"({"stage_timeout": {"at": [1, 0]}})")), "faults.stage_timeout.at[1]");
  EXPECT_EQ(FieldOf(json::parse(R"({"stage_timeout": {"at": [2.5]}})")), "faults.stage_timeout.at[0]");
  EXPECT_EQ(FieldOf(json::parse(R"({"stage_timeout": {"at": []}})")), "faults.stage_timeout.at");
  EXPECT_EQ(FieldOf(json::parse(R"({"stage_timeout": {"at": [4, 2, 4]}})")), "faults.stage_timeout.at");
  EXPECT_EQ(FieldOf(json::parse(R"({"stage_stall": {"at": [1], "device": "turntabel"}})")),
            "faults.stage_stall.device");
  EXPECT_EQ(FieldOf(json::parse(R"({"lamp_failure": [{"at": [1]}, {"at": [1], "device": "lamp1"}]})")),
            "faults.lamp_failure[1].device");
  EXPECT_EQ(FieldOf(json::parse(R"({"lamp_failure": {"at": [1], "when": "now"}})")), "faults.lamp_failure.when");
  EXPECT_EQ(FieldOf(json::parse(R"([1, 2])")), "faults");
}

TEST(FaultPlanJson, LivesInARigDescriptionOrAFileOfItsOwn) {
  auto json = core::ReadJsonFile(RigFile("tiny"));
  json["faults"] = nlohmann::json::parse(R"({"camera_disconnect": {"device": "cam0", "at": [2]}})");
  const auto rig = formats::ParseRigDescription(json, "tiny-faulty.json");
  const FaultPlan plan = FaultPlanOfRig(rig);
  ASSERT_EQ(plan.rules.size(), 1u);
  EXPECT_EQ(plan.rules[0].kind, FaultKind::kCameraDisconnect);
  EXPECT_TRUE(FaultPlanOfRig(Tiny()).empty());

  StateEchoRenderer renderer;
  renderer.rig = rig;
  SimulatedRigBackend backend(renderer, plan, 1);
  auto built = drivers::BuildRig(rig, {{"sim", &backend}});
  built.cameras[0]->Trigger();
  EXPECT_THROW(built.cameras[0]->Grab(milliseconds(100)), drivers::DisconnectedError);

  const auto file = std::filesystem::path(testing::TempDir()) / "sim_devices_test_faults.json";
  {
    std::ofstream out(file);
    out << R"({"format": "mesocap.faults", "version": 1, "stage_timeout": {"rate": 0.25}})";
  }
  const FaultPlan from_file = ReadFaultPlan(file);
  ASSERT_EQ(from_file.rules.size(), 1u);
  EXPECT_EQ(from_file.rules[0].rate, 0.25);
  {
    std::ofstream out(file);
    out << R"({"stage_timeout": {"rate": 0.25}})";
  }
  EXPECT_THROW(ReadFaultPlan(file), core::FormatError);
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace mesocap::sim
