// The devices of the simulated rig, behind the drivers/ interfaces. They
// change a shared SimulatedRigState instead of hardware, keep simulated time
// in state.clock_s (a move advances it by angle / speed; nobody sleeps), and
// fail when their FaultSchedules say so (sim/fault_plan.h). Made by
// SimulatedRigBackend (sim/simulated_rig_backend.h).
//
// Ownership: every device shares the state with the backend through a
// std::shared_ptr, so a Rig may outlive the backend that built it. The
// FrameRenderer belongs to the caller and must outlive the cameras.
// Not thread-safe: the devices share the state and its clock, so one thread
// drives the simulated rig.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drivers/camera.h"
#include "drivers/lamp_bank.h"
#include "drivers/laser_unit.h"
#include "drivers/rotary_stage.h"
#include "formats/rig_description.h"
#include "sim/fault_plan.h"
#include "sim/simulated_rig_state.h"

namespace mesocap::sim {

// The settings a simulated camera takes (DeviceError outside them).
inline constexpr double kMinExposureUs = 1.0;
inline constexpr double kMaxExposureUs = 10e6;
inline constexpr double kMaxGainDb = 48.0;

// What the simulated camera's sensor does to the signal.
enum class SensorModel {
  kIdeal,      // clamps to [0, 1]: exact values, for tests of device logic
  kNoiseless,  // quantizes to the bit depth and saturates (camera_sensor.h)
  kNoisy,      // and adds shot and read noise: what a real camera delivers
};

// Renders through the FrameRenderer, whose image is the signal at the
// description's exposure_us and 0 dB gain; the camera scales it by
// exposure / exposure_us and by the gain (dB of amplitude, 10^(dB/20)),
// crops the region, applies its SensorModel and counts the saturated pixels
// (any channel at 1).
//
// A frame's noise is drawn from a generator seeded by the camera's seed, its
// index, the rig state it images (stage angles, lamps, laser, plate) with
// its exposure, gain and region, and how many frames it has delivered of
// that same state in a row, with no change to the rig between them
// (SimulatedRigState::changes): the same capture gives the same images however
// often it was interrupted, resumed, or hit by dropped frames and timeouts
// (a lost frame delivers nothing, so it draws nothing).
//
// Each exposure advances the clock by the exposure time; a frame's
// timestamp is the clock when its exposure began. A dropped frame costs one
// exposure and one sequence number, and the camera goes on to the next.
class SimulatedCamera : public drivers::Camera {
 public:
  SimulatedCamera(const formats::RigDescription& rig, int camera_index, std::shared_ptr<SimulatedRigState> state,
                  FrameRenderer& renderer, const FaultPlan& faults, std::uint64_t seed,
                  SensorModel sensor = SensorModel::kNoisy);

  drivers::CameraInfo info() const override { return info_; }
  drivers::CameraSettings settings() const override { return settings_; }
  bool IsConnected() override { return !disconnected_; }
  void SetExposure(double exposure_us) override;
  void SetGain(double gain_db) override;
  void SetRegion(const drivers::CameraRegion& region) override;
  void SetPixelFormat(drivers::PixelFormat format) override;
  void SetTrigger(drivers::TriggerMode mode) override;
  // In kFreeRun mode the camera streams anyway and a trigger does nothing.
  void Trigger() override;
  // kSoftware mode without a pending Trigger: TimeoutError after `timeout`.
  drivers::Frame Grab(std::chrono::milliseconds timeout) override;

  bool disconnected() const { return disconnected_; }

 private:
  // Counts one call to the camera; throws once it is disconnected.
  void Call();
  [[noreturn]] void Fail(const std::string& problem) const;
  // The key of what a frame images (see the class comment).
  std::uint64_t ImagedStateKey() const;

  std::shared_ptr<SimulatedRigState> state_;
  FrameRenderer* renderer_;
  int index_;
  formats::CameraDescription description_;
  std::uint64_t seed_;
  SensorModel sensor_;
  std::uint64_t last_state_key_ = 0;
  std::uint64_t last_state_changes_ = 0;
  std::uint64_t repeats_of_state_ = 0;
  drivers::CameraInfo info_;
  drivers::CameraSettings settings_;
  double reference_exposure_us_;
  std::uint64_t next_sequence_ = 0;
  int pending_triggers_ = 0;
  bool disconnected_ = false;
  FaultSchedule drop_frame_;
  FaultSchedule timeout_;
  FaultSchedule disconnect_;
};

// The turntable (drives state.turntable_rad) or the light arc
// (state.light_arc_rad). Moves run at the description's speed, the shorter
// way round, starting at the clock when MoveTo is called; the stage and the
// state follow the clock, so two stages started together finish together.
// Homing goes the shorter way to 0 and then approaches the reference switch
// for kHomingApproachS. Position() is the controller's count: a stalled
// stage stands where it stopped while its controller counts the target (the
// steps it lost), so Position() and the state differ until it is homed.
// The state follows the stage at its calls; capture waits for a move to end
// before it grabs, so a frame never needs the angle mid-move.
class SimulatedRotaryStage : public drivers::RotaryStage {
 public:
  enum class Axis { kTurntable, kLightArc };
  static constexpr double kHomingApproachS = 1.0;

  SimulatedRotaryStage(const formats::RigDescription& rig, Axis axis, std::shared_ptr<SimulatedRigState> state,
                       const FaultPlan& faults, std::uint64_t seed);

  std::string id() const override;
  void Home() override;
  bool IsHomed() const override { return homed_; }
  void MoveTo(double angle_rad) override;
  // A move that needs longer than `timeout` throws TimeoutError after
  // `timeout` of simulated time; the stage is still moving from where it got
  // to, and a later wait finishes the move.
  void WaitUntilStopped(std::chrono::milliseconds timeout) override;
  bool IsMoving() const override;
  double Position() const override;

  double speed_rad_per_s() const { return speed_; }

 private:
  struct Move {
    double from = 0.0;   // physical angle
    double delta = 0.0;  // signed, |delta| <= pi
    double start_s = 0.0;
    double duration_s = 0.0;
    double stall_after_s = -1.0;  // < 0: no stall
    bool timeout_fault = false;
  };

  // Where the stage physically is at the current clock.
  double PhysicalAt(double t) const;
  bool StalledAt(double t) const;
  // Moves the state's angle to where the stage is now.
  void Update();
  // A move starting now, with its faults drawn.
  Move Plan(double from, double delta, double duration_s);
  double& StateAngle() const;
  [[noreturn]] void Fail(const std::string& problem) const;

  std::shared_ptr<SimulatedRigState> state_;
  Axis axis_;
  double speed_;
  bool homed_ = false;
  double physical_ = 0.0;  // where it stands when no move is under way
  double target_ = 0.0;    // the last target the controller was given
  double lost_rad_ = 0.0;  // controller count - physical angle, after a stall
  std::optional<Move> move_;
  FaultSchedule stall_;
  FaultSchedule timeout_;
};

// The lamps on the light arc; state.lamps_on has one entry per lamp.
class SimulatedLampBank : public drivers::LampBank {
 public:
  SimulatedLampBank(const formats::RigDescription& rig, std::shared_ptr<SimulatedRigState> state,
                    const FaultPlan& faults, std::uint64_t seed);

  int lamp_count() const override { return static_cast<int>(failure_.size()); }
  void SetLamp(int index, bool on) override;
  bool IsOn(int index) const override;
  bool IsDead(int index) const;
  // A new bulb in a burnt-out lamp's socket (what the person at the rig does
  // before resuming the capture).
  void ReplaceLamp(int index);

 private:
  void CheckIndex(int index) const;

  std::shared_ptr<SimulatedRigState> state_;
  std::vector<FaultSchedule> failure_;  // one per lamp: lamps burn out on their own
  std::vector<bool> dead_;
};

// The laser scan unit. The tilt motor turns at kTiltSpeedRadPerS within
// +-kMaxTiltRad; SetTilt advances the clock by the time it takes.
class SimulatedLaserUnit : public drivers::LaserUnit {
 public:
  static constexpr double kMaxTiltRad = 0.7853981633974483;        // 45 degrees
  static constexpr double kTiltSpeedRadPerS = 0.5235987755982988;  // 30 degrees/s

  SimulatedLaserUnit(const formats::RigDescription& rig, std::shared_ptr<SimulatedRigState> state);

  void SetEnabled(bool on) override;
  bool IsEnabled() const override { return state_->laser_on; }
  // Throws DeviceError beyond +-kMaxTiltRad; TimeoutError when the tilt
  // needs longer than `timeout` (the emitter stops where it got to).
  void SetTilt(double tilt_rad, std::chrono::milliseconds timeout) override;
  double Tilt() const override { return state_->laser_tilt_rad; }
  int mount_count() const override { return mount_count_; }
  int mount() const override { return state_->laser_mount; }
  void SetMount(int mount) override;

 private:
  std::shared_ptr<SimulatedRigState> state_;
  int mount_count_;
};

}  // namespace mesocap::sim
