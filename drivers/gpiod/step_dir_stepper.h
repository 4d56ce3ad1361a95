// A stepper motor behind a step/dir driver board (A4988, DRV8825, TMC2208 in
// standalone mode) on GPIO lines: one pulse on the step line is one
// microstep, the dir line's level chooses the way. Homes on a limit switch.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "core/error.h"
#include "drivers/gpiod/gpio_line.h"
#include "drivers/rotary_stage.h"

namespace mesocap::drivers::gpiod {

struct StepDirStepperOptions {
  std::string id = "stepper";  // names the stage in messages
  GpioLineAddress step;
  // Active: the angle increases. Use active_low to turn the motor the other way.
  GpioLineAddress direction;
  // Active while the stage stands on its reference; position 0 is where it
  // first reads active when approached from the homing side.
  GpioLineAddress limit_switch;
  int full_steps_per_revolution = 200;  // of the motor (1.8 degree steps)
  int microsteps = 16;                  // set by the driver board's jumpers
  double gear_ratio = 1.0;              // motor turns per turn of the stage
  double max_speed_rad_per_s = 0.5;     // of the stage
  double homing_speed_rad_per_s = 0.1;  // towards the switch: slow, to stop on its edge
  bool home_towards_positive = false;   // the way the stage turns to find the switch
  // How long the step line stays active, and how long the dir line must be
  // steady before a step; driver boards ask for 1-2 us of each.
  std::chrono::nanoseconds step_pulse = std::chrono::microseconds(4);
  std::chrono::nanoseconds direction_setup = std::chrono::microseconds(4);

  core::CheckResult Check() const;
  // Microsteps for one radian of the stage.
  double steps_per_rad() const;
};

// Moves are open loop: the position is the count of steps sent since homing.
// MoveTo only sets the target; WaitUntilStopped sends the pulses (the
// calling thread times them), so IsMoving() is false after it returns.
class StepDirStepper : public RotaryStage {
 public:
  // Throws DeviceError for options that fail Check() or lines that cannot be
  // requested.
  StepDirStepper(StepDirStepperOptions options, const GpioChipOpener& open, GpioTiming timing = GpioTiming::Real());

  std::string id() const override { return options_.id; }
  // Steps off the switch when it is already active, then towards it at the
  // homing speed; StallError naming the switch when it does not change
  // within one turn.
  void Home() override;
  bool IsHomed() const override { return homed_; }
  void MoveTo(double angle_rad) override;
  // TimeoutError when steps remain after `timeout`; the move stays under way
  // and a later wait sends the rest.
  void WaitUntilStopped(std::chrono::milliseconds timeout) override;
  bool IsMoving() const override { return remaining_steps_ != 0; }
  double Position() const override;

  // Steps from the reference, signed, as counted.
  std::int64_t position_steps() const { return position_steps_; }
  // Steps in one turn of the stage, rounded up.
  std::int64_t steps_per_turn() const;

 private:
  // Sends one step the way `positive` says, `period` after the previous one.
  void Step(bool positive, std::chrono::nanoseconds period);
  // Steps the way `positive` says until the switch reads `active`; false when
  // it did not within one turn.
  bool StepUntilSwitch(bool positive, bool active);
  std::chrono::nanoseconds PeriodAt(double speed_rad_per_s) const;
  [[noreturn]] void Fail(const std::string& problem) const;

  StepDirStepperOptions options_;
  GpioTiming timing_;
  std::unique_ptr<GpioOutputLine> step_;
  std::unique_ptr<GpioOutputLine> direction_;
  std::unique_ptr<GpioInputLine> limit_switch_;
  double steps_per_rad_;
  bool homed_ = false;
  bool positive_ = true;                   // the level the dir line holds
  std::chrono::nanoseconds last_step_{0};  // when the last step began
  std::int64_t position_steps_ = 0;
  std::int64_t remaining_steps_ = 0;  // signed: still to send for the move
};

}  // namespace mesocap::drivers::gpiod
