// A real rig as the capture daemon opens it (pipelines/rig_station.h), with
// the most real devices this machine has: cameras served as GigE Vision
// devices on loopback and driven through Aravis, turntable and light arc on
// emulated Pololu Tics over their USB protocol, lamps and the laser (enable
// and a step/dir tilt motor with its limit switch) on an emulated GPIO chip.
// A capture runs through the daemon with every operator step asked and
// acknowledged, journals every step and counts every frame; the devices
// report their states; a run without a person to ask is refused. The served
// cameras render the simulated rig's own state, which these devices do not
// drive, so the images are not compared with truth here (the simulated
// station's tests do that).
#include <gtest/gtest.h>

#include <fstream>
#include <thread>

#include "acquisition/capture_daemon.h"
#include "core/json_field_reader.h"
#include "drivers/aravis/aravis_rig_backend.h"
#include "drivers/gpiod/emulated_gpio_chip.h"
#include "drivers/gpiod/gpiod_rig_backend.h"
#include "drivers/tic/emulated_tic.h"
#include "drivers/tic/tic_rig_backend.h"
#include "formats/calibration.h"
#include "pipelines/rig_station.h"
#include "pipelines/simulated_station.h"
#include "sim/camera_renderer.h"
#include "sim/mesostructure_scene.h"
#include "sim/served_cameras.h"
#include "sim/simulated_rig_backend.h"
#include "sim/true_calibration.h"
#include "tests/common/file_bytes.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::pipelines {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

constexpr const char* kTurntableSerial = "00300001";
constexpr const char* kLightArcSerial = "00300002";

drivers::tic::EmulatedTicOptions TicOptions(const char* serial) {
  drivers::tic::EmulatedTicOptions o;
  o.serial_number = serial;
  o.home_switch_microsteps = 400;
  o.revolution_microsteps = 1600;  // 200 full steps at 1/8, direct drive
  o.max_speed = 80000000;          // 8000 microsteps/s
  o.homing_speed = 8000000;
  return o;
}

class RigStationTest : public ::testing::Test {
 protected:
  RigStationTest() {
    // The cameras: the one-sweep tiny rig's, simulated and served.
    sim_rig_ = formats::ParseRigDescription(testing::OneSweepRig(), "rig.json");
    renderer_ = std::make_unique<sim::CameraRenderer>(*scene_, sim_rig_, sim::CameraRendererOptions{1});
    backend_ = std::make_unique<sim::SimulatedRigBackend>(*renderer_, sim::FaultPlan{}, 3);
    served_ = sim::ServeRigCameras(sim_rig_, *backend_);
    // The same rig with real backends for every device.
    json rig = testing::OneSweepRig();
    for (std::size_t i = 0; i < rig["cameras"].size(); ++i) {
      rig["cameras"][i].update({{"backend", "aravis"}, {"device", served_->address(i).address}});
    }
    rig["turntable"].update({{"backend", "tic"}, {"serial", kTurntableSerial}, {"microsteps", 8}});
    rig["light_arc"].update({{"backend", "tic"}, {"serial", kLightArcSerial}, {"microsteps", 8}});
    json lamp_lines = json::array();
    std::vector<std::string> names;
    for (std::size_t i = 0; i < rig["lamps"]["elevations_deg"].size(); ++i) {
      names.push_back("LAMP" + std::to_string(i));
      lamp_lines.push_back({{"chip", "gpiochip0"}, {"line", names.back()}});
    }
    for (const char* name : {"LASER_EN", "STEP", "DIR", "HOME"}) names.push_back(name);
    rig["lamps"].update({{"backend", "gpiod"}, {"lines", lamp_lines}, {"settle_ms", 1}});
    rig["laser"].update({{"backend", "gpiod"},
                         {"enable", {{"chip", "gpiochip0"}, {"line", "LASER_EN"}}},
                         {"tilt",
                          {{"backend", "gpiod"},
                           {"step", {{"chip", "gpiochip0"}, {"line", "STEP"}}},
                           {"direction", {{"chip", "gpiochip0"}, {"line", "DIR"}}},
                           {"limit_switch", {{"chip", "gpiochip0"}, {"line", "HOME"}}},
                           {"microsteps", 1}}}});
    rig_file_ = testing::WriteRig(dir_ / "real-rig.json", rig);
    formats::WriteCalibration(dir_ / "calibration.json", sim::TrueCalibration(sim_rig_));
    chip_ = std::make_unique<drivers::gpiod::EmulatedGpioChip>("gpiochip0", names);
    AttachTiltMotor();
  }

  // The tilt motor on STEP and DIR: a step a rising edge; its limit switch
  // HOME pressed within 3 steps below its reference.
  void AttachTiltMotor() {
    const int step = chip_->OffsetOf("STEP"), dir = chip_->OffsetOf("DIR"), home = chip_->OffsetOf("HOME");
    chip_->OnWrite([this, step, dir, home](const drivers::gpiod::EmulatedGpioWrite& write) {
      if (write.offset == step && write.high) tilt_steps_ += chip_->IsHigh(dir) ? 1 : -1;
      chip_->Drive(home, tilt_steps_ <= 0 && tilt_steps_ > -3);
    });
    tilt_steps_ = 40;  // where it powered up
  }

  std::vector<std::unique_ptr<drivers::RigBackend>> Backends() {
    std::vector<std::unique_ptr<drivers::RigBackend>> backends;
    backends.push_back(std::make_unique<drivers::aravis::AravisRigBackend>());
    backends.push_back(std::make_unique<drivers::tic::TicRigBackend>(
        [this](const std::string& serial) { return TicOf(serial).Opener()(serial); },
        [this](const std::string& serial) { return TicOf(serial).MakeClock(); }));
    backends.push_back(std::make_unique<drivers::gpiod::GpiodRigBackend>(chip_->Opener()));
    return backends;
  }
  drivers::tic::EmulatedTic& TicOf(const std::string& serial) {
    return serial == kTurntableSerial ? turntable_ : light_arc_;
  }
  RigStationOptions Options() const { return {rig_file_, dir_ / "calibration.json"}; }

  testing::TemporaryDirectory dir_;
  std::unique_ptr<sim::MesostructureScene> scene_ = sim::MakeBuiltinScene("weave");
  formats::RigDescription sim_rig_;
  std::unique_ptr<sim::CameraRenderer> renderer_;
  std::unique_ptr<sim::SimulatedRigBackend> backend_;
  std::unique_ptr<sim::ServedCameras> served_;
  std::string rig_file_;
  drivers::tic::EmulatedTic turntable_{TicOptions(kTurntableSerial)};
  drivers::tic::EmulatedTic light_arc_{TicOptions(kLightArcSerial)};
  std::unique_ptr<drivers::gpiod::EmulatedGpioChip> chip_;
  int tilt_steps_ = 0;
};

TEST_F(RigStationTest, ACaptureThroughTheDaemonAsksTheOperatorAndJournalsEveryStep) {
  auto station = std::make_unique<RigStation>(Options(), Backends());
  EXPECT_EQ(station->camera_ids().size(), sim_rig_.cameras.size());
  acquisition::CaptureDaemonOptions o;
  o.state_dir = dir_ / "state";
  o.prompt_operator = true;
  acquisition::CaptureDaemon daemon(std::move(station), o);
  const std::string id = daemon.Submit("capture").id;
  daemon.Start();
  std::vector<std::string> prompts;
  const auto deadline = std::chrono::steady_clock::now() + 5min;
  while (!acquisition::IsFinished(daemon.Job(id)->state) && daemon.Job(id)->state != acquisition::JobState::kPaused &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(2ms);
  }
  for (acquisition::CaptureJob job; (job = *daemon.Job(id)).state != acquisition::JobState::kDone;) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << acquisition::ToString(job.state);
    ASSERT_FALSE(job.paused_by_fault) << job.pause_reason;
    ASSERT_NE(job.state, acquisition::JobState::kFailed) << job.error;
    if (!job.operator_prompt.empty()) {
      prompts.push_back(job.operator_prompt);
      daemon.Ack(id);
    }
    std::this_thread::sleep_for(2ms);
  }
  const acquisition::CaptureJob done = *daemon.Job(id);
  EXPECT_EQ(done.steps_done, done.steps_total);
  EXPECT_GT(done.frames, 0u);     // a frame lost on a loaded loopback is taken again: dropped_frames may be above 0
  ASSERT_GE(prompts.size(), 4u);  // each calibration plate laid and taken off
  EXPECT_NE(prompts.front().find("calibration plate"), std::string::npos) << prompts.front();
  // The session holds the calibration it was given.
  EXPECT_EQ(testing::Slurp(daemon.SessionDir(id) / "calibration.json"), testing::Slurp(dir_ / "calibration.json"));
  // The devices say what they are and where they stand.
  const acquisition::CaptureDaemon::RigStatus status = daemon.DeviceStates();
  ASSERT_EQ(status.devices.size(), sim_rig_.cameras.size() + 4);
  for (const drivers::DeviceState& d : status.devices) EXPECT_TRUE(d.ok) << d.device << ": " << d.state;
  EXPECT_NE(status.devices[sim_rig_.cameras.size()].state.find("homed"), std::string::npos);
  EXPECT_EQ(status.devices.back().state.substr(0, 3), "off");
  // The same frames a simulated rig's capture of the same plan counts.
  SimulatedStationOptions simulated;
  simulated.rig = testing::WriteRig(dir_ / "sim-rig.json");
  SimulatedStation reference(simulated);
  reference.OpenSession(dir_ / "reference", "capture");
  acquisition::CaptureRunnerOptions run;
  run.show_progress = false;
  EXPECT_EQ(done.frames, reference.RunSession(dir_ / "reference", run, {}).frames);
}

TEST_F(RigStationTest, ARunWithoutAPersonToAskIsRefusedBeforeAnythingMoves) {
  RigStation station(Options(), Backends());
  station.OpenSession(dir_ / "session", "capture");
  acquisition::CaptureRunnerOptions run;
  run.show_progress = false;
  try {
    station.RunSession(dir_ / "session", run, {});
    FAIL() << "ran without an operator prompt";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("need a person; run mesocapd with --prompt-operator"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(turntable_.shaft_microsteps(), 0.0);
}

TEST_F(RigStationTest, AWrongRigOrCalibrationIsNamed) {
  const auto error_of = [&](const RigStationOptions& o) {
    try {
      RigStation station(o, Backends());
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_NE(error_of({rig_file_, ""}).find("calibration: a real rig needs its calibration file"), std::string::npos);
  EXPECT_NE(error_of({rig_file_, dir_ / "missing.json"}).find("missing.json"), std::string::npos);
  const std::string simulated = testing::WriteRig(dir_ / "sim-rig.json");
  EXPECT_NE(error_of({simulated, dir_ / "calibration.json"}).find("every device is simulated"), std::string::npos);
  EXPECT_FALSE(DrivesRealDevices(sim_rig_));
}

}  // namespace
}  // namespace mesocap::pipelines
