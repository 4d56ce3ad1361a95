#include "drivers/gpiod/step_dir_stepper.h"
#include "core/angles.h"

#include <cmath>
#include <numbers>

#include "drivers/device_error.h"

namespace mesocap::drivers::gpiod {
namespace {

double Wrap(double angle) {
  double wrapped = std::fmod(angle, core::kTwoPi);
  if (wrapped < 0.0) wrapped += core::kTwoPi;
  return wrapped < core::kTwoPi ? wrapped : 0.0;  // -1e-17 wraps to 2 pi in doubles
}

std::string Speed(double rad_per_s) { return std::to_string(rad_per_s) + " rad/s"; }

}  // namespace

double StepDirStepperOptions::steps_per_rad() const {
  return full_steps_per_revolution * static_cast<double>(microsteps) * gear_ratio / core::kTwoPi;
}

core::CheckResult StepDirStepperOptions::Check() const {
  if (id.empty()) return "id: empty (names the stage in messages)";
  if (std::string problem = CheckLines({{"step", &step}, {"direction", &direction}, {"limit_switch", &limit_switch}});
      !problem.empty()) {
    return problem;
  }
  if (full_steps_per_revolution < 1) {
    return "full_steps_per_revolution: " + std::to_string(full_steps_per_revolution) + " (1 or more)";
  }
  if (microsteps < 1 || microsteps > 256) return "microsteps: " + std::to_string(microsteps) + " (1 to 256)";
  if (!(std::isfinite(gear_ratio) && gear_ratio > 0.0)) {
    return "gear_ratio: " + std::to_string(gear_ratio) + " (motor turns a stage turn, above 0)";
  }
  if (!(std::isfinite(max_speed_rad_per_s) && max_speed_rad_per_s > 0.0)) {
    return "max_speed_rad_per_s: " + Speed(max_speed_rad_per_s) + " (above 0)";
  }
  if (!(std::isfinite(homing_speed_rad_per_s) && homing_speed_rad_per_s > 0.0 &&
        homing_speed_rad_per_s <= max_speed_rad_per_s)) {
    return "homing_speed_rad_per_s: " + Speed(homing_speed_rad_per_s) + " (above 0, at most max_speed_rad_per_s " +
           Speed(max_speed_rad_per_s) + ")";
  }
  if (step_pulse.count() <= 0) return "step_pulse: " + std::to_string(step_pulse.count()) + " ns (above 0)";
  if (direction_setup.count() < 0) {
    return "direction_setup: " + std::to_string(direction_setup.count()) + " ns (0 or more)";
  }
  // The step line must be inactive between pulses at least as long as active.
  const double period_ns = 1e9 / (max_speed_rad_per_s * steps_per_rad());
  if (period_ns < 2.0 * static_cast<double>(step_pulse.count())) {
    return "max_speed_rad_per_s: " + Speed(max_speed_rad_per_s) + " needs a step every " + std::to_string(period_ns) +
           " ns, shorter than twice step_pulse (" + std::to_string(step_pulse.count()) + " ns)";
  }
  return "";
}

StepDirStepper::StepDirStepper(StepDirStepperOptions options, const GpioChipOpener& open, GpioTiming timing)
    : options_(std::move(options)), timing_(std::move(timing)) {
  core::ThrowIfInvalid<DeviceError>(options_.Check(), "stepper " + options_.id);
  GpioChips chips(open);
  step_ = chips.RequestOutput(options_.step);
  // Requested inactive: the dir line says "negative" until a move says otherwise.
  direction_ = chips.RequestOutput(options_.direction);
  positive_ = false;
  limit_switch_ = chips.RequestInput(options_.limit_switch);
  steps_per_rad_ = options_.steps_per_rad();
  last_step_ = timing_.now();
}

std::chrono::nanoseconds StepDirStepper::PeriodAt(double speed_rad_per_s) const {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(std::ceil(1e9 / (speed_rad_per_s * steps_per_rad_))));
}

void StepDirStepper::Fail(const std::string& problem) const { throw DeviceError(options_.id + ": " + problem); }

void StepDirStepper::Step(bool positive, std::chrono::nanoseconds period) {
  if (positive != positive_) {
    direction_->SetActive(positive);
    positive_ = positive;
    timing_.sleep(options_.direction_setup);
  }
  // Timed from the previous step as it happened, so a late wake-up makes the
  // motor slower, never faster than it can follow.
  const std::chrono::nanoseconds wait = last_step_ + period - timing_.now();
  if (wait.count() > 0) timing_.sleep(wait);
  last_step_ = timing_.now();
  step_->SetActive(true);
  timing_.sleep(options_.step_pulse);
  step_->SetActive(false);
  position_steps_ += positive ? 1 : -1;
}

std::int64_t StepDirStepper::steps_per_turn() const {
  const double turn =
      options_.full_steps_per_revolution * static_cast<double>(options_.microsteps) * options_.gear_ratio;
  // Up, but not for the rounding error of a whole number of steps.
  return static_cast<std::int64_t>(std::ceil(turn * (1.0 - 1e-12)));
}

bool StepDirStepper::StepUntilSwitch(bool positive, bool active) {
  const std::int64_t turn = steps_per_turn();
  const std::chrono::nanoseconds period = PeriodAt(options_.homing_speed_rad_per_s);
  for (std::int64_t sent = 0;; ++sent) {
    if (limit_switch_->IsActive() == active) return true;
    if (sent == turn) return false;
    Step(positive, period);
  }
}

void StepDirStepper::Home() {
  homed_ = false;
  remaining_steps_ = 0;
  const bool towards = options_.home_towards_positive;
  const std::string turn = " within one turn (" + std::to_string(steps_per_turn()) + " steps)";
  // Leave the switch first, so that 0 is always its edge on the homing side.
  if (limit_switch_->IsActive() && !StepUntilSwitch(!towards, false)) {
    throw StallError(options_.id + ": limit switch " + limit_switch_->description() + " stayed active" + turn);
  }
  if (!StepUntilSwitch(towards, true)) {
    throw StallError(options_.id + ": limit switch " + limit_switch_->description() + " did not switch" + turn);
  }
  position_steps_ = 0;
  homed_ = true;
}

void StepDirStepper::MoveTo(double angle_rad) {
  if (!std::isfinite(angle_rad)) Fail("target angle is not a number");
  if (!homed_) Fail("not homed (position unknown); call Home() first");
  const double delta = std::remainder(Wrap(angle_rad) - Position(), core::kTwoPi);
  remaining_steps_ = std::llround(delta * steps_per_rad_);
}

void StepDirStepper::WaitUntilStopped(std::chrono::milliseconds timeout) {
  const std::chrono::nanoseconds start = timing_.now();
  const std::chrono::nanoseconds period = PeriodAt(options_.max_speed_rad_per_s);
  while (remaining_steps_ != 0) {
    if (timing_.now() - start >= timeout) {
      throw TimeoutError(options_.id + ": " + std::to_string(std::llabs(remaining_steps_)) +
                         " steps short of the target after " + std::to_string(timeout.count()) + " ms");
    }
    const bool positive = remaining_steps_ > 0;
    try {
      Step(positive, period);
    } catch (const DeviceError&) {
      // Whether the motor took the step is unknown.
      homed_ = false;
      remaining_steps_ = 0;
      throw;
    }
    remaining_steps_ += positive ? -1 : 1;
  }
}

double StepDirStepper::Position() const { return Wrap(static_cast<double>(position_steps_) / steps_per_rad_); }

}  // namespace mesocap::drivers::gpiod
