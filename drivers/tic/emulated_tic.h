// An emulated Tic for tests: a state machine that answers the control
// transfers a real Tic answers (tic_protocol.h), in emulated time that the
// test (or a stage sleeping on the Tic's clock) advances; nobody sleeps.
//
// What it models: the step count, target and velocity (a constant speed,
// the "max speed" last set; no acceleration), the command timeout (only
// "reset command timeout" restarts it, so a host that only polls times out),
// safe start after power-up and after any error, a home switch every
// revolution at a step position for "go home", and injected failures: a
// stall (the count stops while the velocity stays, as when steps are lost
// and the count follows the shaft), loss of motor power (low VIN, the motor
// de-energized), USB timeouts, and an unplug (every transfer on an open
// connection fails as disconnected; after PlugIn the Tic can be opened
// again by serial number). Requests it does not know, or with the wrong
// direction or length, fail as a real Tic stalls its control pipe.
//
// The EmulatedTic must outlive the transports and clocks it hands out.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "drivers/tic/stage_clock.h"
#include "drivers/tic/tic_protocol.h"
#include "drivers/tic/tic_transport.h"

namespace mesocap::drivers::tic {

struct EmulatedTicOptions {
  std::string serial_number = "00000001";
  TicProduct product = TicProduct::kT825;
  // The Tic's command timeout setting; 0 turns it off.
  std::chrono::milliseconds command_timeout{kDefaultCommandTimeoutMs};
  // Microsteps (at the step mode in force) from the power-up position to
  // the home switch; it is hit again every `revolution_microsteps` when
  // that is above 0 (a rotary axis).
  std::int64_t home_switch_microsteps = 0;
  std::int64_t revolution_microsteps = 0;
  // Speeds in microsteps per 10000 s, as the Tic counts them.
  std::uint32_t max_speed = 2000000;
  std::uint32_t homing_speed = 1000000;
  std::uint16_t vin_mv = 12000;
};

class EmulatedTic {
 public:
  explicit EmulatedTic(EmulatedTicOptions options);

  const EmulatedTicOptions& options() const { return options_; }
  TicDeviceInfo info() const;

  // Emulated time since construction; Advance runs the Tic through it.
  std::chrono::nanoseconds now() const { return now_; }
  void Advance(std::chrono::nanoseconds duration);
  // A clock whose SleepFor advances this Tic's time.
  std::unique_ptr<StageClock> MakeClock();

  // Answers one control transfer as the Tic would (no connection checks).
  // Throws DeviceError naming the request for one the Tic rejects.
  std::size_t Answer(const ControlSetup& setup, std::span<std::uint8_t> data);

  // A connection to the Tic as it is plugged in now.
  std::unique_ptr<TicTransport> Open();
  // Opens by serial number while plugged in; DeviceError "no Tic with
  // serial X found (found: ...)" otherwise.
  TicOpener Opener();

  // Failure injection.
  void Stall(bool stalled) {
    Update();
    stalled_ = stalled;
  }
  void LoseMotorPower();
  void RestoreMotorPower();
  void FailNextTransfersWithTimeout(int count) { timeouts_to_inject_ = count; }
  // Unplugs the USB cable; open connections fail from now on.
  void Unplug();
  // Plugs it back in; `power_cycled`: the Tic restarted (count 0, position
  // uncertain, safe start) as when it was powered from USB alone.
  void PlugIn(bool power_cycled);

  // What the host sees and did, for assertions.
  TicVariables Variables() const;
  bool plugged_in() const { return plugged_in_; }
  int connection() const { return connection_; }
  int commands_received(TicCommand command) const;
  // Microsteps the shaft turned since power-up (differs from the count after
  // a stall or a set position).
  double shaft_microsteps() const { return shaft_; }

 private:
  friend class EmulatedTicTransport;

  void PowerUp();
  void Update();
  void SetError(TicErrorBit bit);
  void ClearError(TicErrorBit bit);
  void Halt();
  bool Moving() const;
  int Direction() const;
  double SpeedMicrostepsPerSecond() const;
  double Count() const { return shaft_ + count_offset_; }
  // Shaft position of the next home switch in the homing direction.
  std::optional<double> NextSwitch() const;
  bool CommandTimeoutArmed() const;
  void Execute(TicCommand command, std::uint32_t argument);
  [[noreturn]] void Reject(const ControlSetup& setup, const std::string& why) const;

  EmulatedTicOptions options_;
  std::chrono::nanoseconds now_{0};
  std::chrono::nanoseconds updated_to_{0};  // the time the state is at
  std::chrono::nanoseconds last_timeout_reset_{0};
  double shaft_ = 0.0;         // microsteps since power-up
  double count_offset_ = 0.0;  // the Tic's count minus shaft_
  std::int32_t target_ = 0;
  TicPlanningMode planning_ = TicPlanningMode::kOff;
  bool homing_ = false;
  HomingDirection homing_direction_ = HomingDirection::kReverse;
  bool position_uncertain_ = true;
  std::uint16_t error_status_ = 0;
  std::uint32_t errors_occurred_ = 0;
  std::uint32_t max_speed_ = 0;
  std::uint8_t step_mode_ = 0;
  std::uint16_t vin_mv_ = 0;
  bool stalled_ = false;
  bool plugged_in_ = true;
  int connection_ = 0;  // counts unplugs: a connection opened before one is dead
  int timeouts_to_inject_ = 0;
  std::map<std::uint8_t, int> commands_received_;
};

}  // namespace mesocap::drivers::tic
