#include "drivers/tic/tic_rotary_stage.h"
#include "core/angles.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "drivers/device_error.h"

namespace mesocap::drivers::tic {
namespace {

// Errors an idle Tic collects when nobody resets its command timeout; the
// next move clears them.
constexpr std::uint32_t kIdleErrors =
    ErrorMask(TicErrorBit::kCommandTimeout) | ErrorMask(TicErrorBit::kSafeStartViolation);

std::string Radians(double angle) {
  std::ostringstream text;
  text.precision(4);
  text << angle << " rad";
  return text.str();
}

std::chrono::nanoseconds Seconds(double seconds) {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(std::ceil(seconds * 1e9)));
}

}  // namespace

core::CheckResult TicStageOptions::Check() const {
  if (id.empty()) return "id is empty";
  if (serial_number.empty()) return "serial_number is empty: name the Tic to open";
  if (full_steps_per_revolution <= 0) return "full_steps_per_revolution must be positive";
  if (!StepModeCode(microsteps))
    return "microsteps must be a power of two from 1 to 256, not " + std::to_string(microsteps);
  if (microsteps > MaxMicrosteps(product)) {
    return ProductName(product) + " offers at most " + std::to_string(MaxMicrosteps(product)) + " microsteps, not " +
           std::to_string(microsteps);
  }
  if (!(gear_ratio > 0.0) || !std::isfinite(gear_ratio)) return "gear_ratio must be positive";
  // The Tic counts in 32 bits; a few hundred turns either way must fit.
  if (MicrostepsPerRevolution() > 1e6) return "more than a million microsteps per revolution";
  if (!(max_speed_rad_per_s > 0.0) || !std::isfinite(max_speed_rad_per_s)) {
    return "max_speed_rad_per_s must be positive";
  }
  if (SpeedUnits() < 1.0) return "max_speed_rad_per_s is below the Tic's slowest speed";
  if (SpeedUnits() > kMaxSpeedUnits) return "max_speed_rad_per_s needs more than the Tic's 50000 steps/s";
  if (command_timeout.count() < 0) return "command_timeout must not be negative";
  if (keepalive_period.count() <= 0) return "keepalive_period must be positive";
  if (command_timeout.count() > 0 && keepalive_period > command_timeout / 2) {
    return "keepalive_period must be at most half of command_timeout (" + std::to_string(command_timeout.count()) +
           " ms)";
  }
  if (poll_period.count() <= 0) return "poll_period must be positive";
  if (homing_timeout.count() <= 0) return "homing_timeout must be positive";
  if (stall_margin.count() < 0) return "stall_margin must not be negative";
  return "";
}

double TicStageOptions::MicrostepsPerRevolution() const {
  return static_cast<double>(full_steps_per_revolution) * microsteps * gear_ratio;
}

double TicStageOptions::SpeedUnits() const {
  return max_speed_rad_per_s / core::kTwoPi * MicrostepsPerRevolution() * kSpeedUnitsPerStepPerSecond;
}

TicRotaryStage::TicRotaryStage(TicStageOptions options, TicOpener opener, std::unique_ptr<StageClock> clock)
    : options_(std::move(options)), opener_(std::move(opener)), clock_(std::move(clock)) {
  core::ThrowIfInvalid(options_.Check(), "Tic stage " + options_.id);
  transport_ = opener_(options_.serial_number);
  Configure();
}

std::string TicRotaryStage::Name() const {
  return "Tic stage " + options_.id + " (serial " + options_.serial_number + ")";
}

void TicRotaryStage::Configure() {
  if (transport_->info().product != options_.product) {
    throw DeviceError(Name() + ": the Tic is a " + transport_->info().product_name + ", the options name a " +
                      ProductName(options_.product));
  }
  // Step mode and speed set by command last until the Tic resets, so they
  // are sent on every open.
  Send(EncodeCommand(TicCommand::kSetStepMode, *StepModeCode(options_.microsteps)));
  Send(EncodeCommand(TicCommand::kSetMaxSpeed, static_cast<std::uint32_t>(std::lround(options_.SpeedUnits()))));
  Send(EncodeCommand(TicCommand::kResetCommandTimeout));
  last_keepalive_ = clock_->Now();
  if (ReadVariables().position_uncertain) homed_ = false;
}

void TicRotaryStage::Reopen() {
  // Opened before the old one is let go: when this fails, the stage keeps
  // its dead transport and goes on throwing DisconnectedError.
  std::unique_ptr<TicTransport> transport = opener_(options_.serial_number);
  transport_ = std::move(transport);
  move_pending_ = false;
  Configure();
}

std::size_t TicRotaryStage::Transfer(const ControlSetup& setup, std::span<std::uint8_t> data) const {
  // The transport's message names the USB request; this one adds the stage.
  try {
    return transport_->ControlTransfer(setup, data);
  } catch (const DisconnectedError& e) {
    throw DisconnectedError(Name() + ": " + e.what() + "; Reopen() it");
  } catch (const TimeoutError& e) {
    throw TimeoutError(Name() + ": " + e.what());
  } catch (const DeviceError& e) {
    throw DeviceError(Name() + ": " + e.what());
  }
}

void TicRotaryStage::Send(const ControlSetup& setup) const { Transfer(setup, {}); }

TicVariables TicRotaryStage::ReadVariables() const {
  std::array<std::uint8_t, kVariablesBlockSize> block{};
  const std::size_t received = Transfer(EncodeGetVariables(0, kVariablesBlockSize, false), block);
  if (received != block.size()) {
    throw DeviceError(Name() + ": read " + std::to_string(received) + " bytes of variables, expected " +
                      std::to_string(block.size()));
  }
  return DecodeVariables(block);
}

void TicRotaryStage::ThrowOnErrors(const TicVariables& variables) {
  if (variables.error_status == 0) return;
  move_pending_ = false;
  if (variables.position_uncertain) homed_ = false;
  throw DeviceError(Name() + ": the Tic stopped the motor: " + DescribeErrors(variables.error_status) +
                    " (operation state " + OperationStateName(variables.operation_state) + ")");
}

TicVariables TicRotaryStage::Prepare(bool need_position) {
  Send(EncodeCommand(TicCommand::kResetCommandTimeout));
  last_keepalive_ = clock_->Now();
  TicVariables variables = ReadVariables();
  if (variables.error_status & ~kIdleErrors) ThrowOnErrors(variables);
  if (variables.error_status != 0) {
    Send(EncodeCommand(TicCommand::kExitSafeStart));
    variables = ReadVariables();
    ThrowOnErrors(variables);
  }
  if (need_position && variables.position_uncertain) {
    homed_ = false;
    throw DeviceError(Name() + ": the Tic's position is uncertain (it lost power or was de-energized); home it");
  }
  return variables;
}

void TicRotaryStage::ThrowIfStanding(const TicVariables& variables, StandingCount& standing) {
  const std::chrono::nanoseconds now = clock_->Now();
  if (variables.current_velocity == 0 || variables.current_position != standing.position) {
    standing = {variables.current_position, now};
    return;
  }
  // The count should change every 1 / speed seconds.
  const double step_s = kSpeedUnitsPerStepPerSecond / std::abs(static_cast<double>(variables.current_velocity));
  if (now - standing.since > options_.stall_margin + Seconds(step_s)) {
    move_pending_ = false;
    homed_ = false;
    Send(EncodeCommand(TicCommand::kHaltAndHold));
    throw StallError(Name() + ": the count stands at " + std::to_string(variables.current_position) +
                     " while the Tic turns the motor: stalled");
  }
}

void TicRotaryStage::KeepAliveAndSleep(std::chrono::nanoseconds deadline) {
  std::chrono::nanoseconds now = clock_->Now();
  if (now - last_keepalive_ >= options_.keepalive_period) {
    Send(EncodeCommand(TicCommand::kResetCommandTimeout));
    last_keepalive_ = now;
  }
  const std::chrono::nanoseconds next_keepalive = last_keepalive_ + options_.keepalive_period;
  const std::chrono::nanoseconds wake = std::min({now + options_.poll_period, next_keepalive, deadline});
  clock_->SleepFor(std::max(wake - now, std::chrono::nanoseconds(1)));
}

void TicRotaryStage::Home() {
  Prepare(false);
  move_pending_ = false;
  homed_ = false;
  Send(EncodeGoHome(options_.homing_direction));
  const std::chrono::nanoseconds deadline = clock_->Now() + options_.homing_timeout;
  StandingCount standing{0, clock_->Now()};
  while (true) {
    const TicVariables variables = ReadVariables();
    ThrowOnErrors(variables);
    if (!variables.homing_active) {
      if (variables.position_uncertain) {
        throw DeviceError(Name() + ": homing ended without finding the home switch");
      }
      break;
    }
    ThrowIfStanding(variables, standing);
    if (clock_->Now() >= deadline) {
      Send(EncodeCommand(TicCommand::kHaltAndHold));
      throw TimeoutError(Name() + ": homing did not find the switch in " +
                         std::to_string(options_.homing_timeout.count()) + " ms");
    }
    KeepAliveAndSleep(deadline);
  }
  // The Tic makes the switch position 0 itself; setting it again makes the
  // stage's zero independent of how the Tic's homing settings back off.
  Send(EncodeHaltAndSetPosition(0));
  target_count_ = 0;
  homed_ = true;
}

void TicRotaryStage::MoveTo(double angle_rad) {
  if (!std::isfinite(angle_rad)) throw DeviceError(Name() + ": MoveTo to a non-finite angle");
  if (!homed_) throw DeviceError(Name() + ": MoveTo before Home(): the position is unknown");
  const TicVariables variables = Prepare(true);
  const std::int32_t from = variables.current_position;
  const double per_revolution = options_.MicrostepsPerRevolution();
  const double turns = std::fmod(angle_rad, core::kTwoPi) / core::kTwoPi;
  // Of the counts at this angle, the one nearest the current count: the
  // shorter way round, with no drift from rounding.
  const double revolutions = std::round(from / per_revolution - turns);
  const double target = std::round((turns + revolutions) * per_revolution);
  if (std::abs(target) > std::numeric_limits<std::int32_t>::max()) {
    throw DeviceError(Name() + ": the Tic's count would overflow; home it again");
  }
  target_count_ = static_cast<std::int32_t>(target);
  Send(EncodeSetTargetPosition(target_count_));
  move_due_ = clock_->Now() + Seconds(MotionSeconds(std::abs(target_count_ - from), variables));
  move_pending_ = true;
}

double TicRotaryStage::MotionSeconds(double microsteps, const TicVariables& variables) const {
  const double speed = options_.SpeedUnits() / kSpeedUnitsPerStepPerSecond;
  double seconds = microsteps / speed;
  // Ramping up and down adds at most speed / (2 accel) each (0: no ramp).
  // Without this a slow-ramping Tic would look stalled at the end of a move.
  for (std::uint32_t ramp : {variables.max_accel, variables.max_decel}) {
    if (ramp > 0) seconds += speed / (2.0 * ramp / kAccelUnitsPerStepPerSecondSquared);
  }
  return seconds;
}

void TicRotaryStage::WaitUntilStopped(std::chrono::milliseconds timeout) {
  const std::chrono::nanoseconds deadline = clock_->Now() + timeout;
  StandingCount standing{0, clock_->Now()};
  while (true) {
    const TicVariables variables = ReadVariables();
    ThrowOnErrors(variables);
    const bool stopped = variables.current_velocity == 0 && !variables.homing_active;
    if (!move_pending_ && stopped) return;
    if (move_pending_ && stopped && variables.current_position == target_count_) {
      move_pending_ = false;
      return;
    }
    if (stopped) {
      move_pending_ = false;
      homed_ = false;
      throw StallError(Name() + ": stopped at " + Radians(AngleOf(variables.current_position)) +
                       " short of its target " + Radians(AngleOf(target_count_)));
    }
    ThrowIfStanding(variables, standing);
    const std::chrono::nanoseconds now = clock_->Now();
    if (move_pending_ && now > move_due_ + options_.stall_margin) {
      move_pending_ = false;
      homed_ = false;
      Send(EncodeCommand(TicCommand::kHaltAndHold));
      throw StallError(Name() + ": still short of its target " + Radians(AngleOf(target_count_)) + " at " +
                       Radians(AngleOf(variables.current_position)) + " after its motion time: stalled");
    }
    if (now >= deadline) {
      throw TimeoutError(Name() + ": still moving after " + std::to_string(timeout.count()) + " ms (at " +
                         Radians(AngleOf(variables.current_position)) + ")");
    }
    KeepAliveAndSleep(deadline);
  }
}

bool TicRotaryStage::IsMoving() const {
  const TicVariables variables = ReadVariables();
  return variables.current_velocity != 0 || variables.homing_active;
}

double TicRotaryStage::AngleOf(std::int32_t count) const {
  const double angle = std::fmod(count / options_.MicrostepsPerRevolution() * core::kTwoPi, core::kTwoPi);
  return angle < 0.0 ? angle + core::kTwoPi : angle;
}

double TicRotaryStage::Position() const { return AngleOf(ReadVariables().current_position); }

}  // namespace mesocap::drivers::tic
