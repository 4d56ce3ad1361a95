// A RotaryStage driven by a Pololu Tic: the turntable, the light arc or the
// laser's tilt motor. Angles map to the Tic's microstep count through the
// motor's full steps, the microstepping and the gear ratio; the Tic moves at
// the options' speed; homing uses the Tic's "go home" with its home switch.
//
// The Tic cannot tell a stall (a stepper that lost steps counts on), so the
// stage judges one: a move that has not reached its target by its motion
// time plus a margin, a motor that stopped short of its target, or a count
// that stands still while the Tic says it turns. The Tic's command timeout
// stops the motor when the host goes quiet, so the stage resets it at least
// every keepalive period while it waits; between calls nobody does, and the
// next move clears the timeout (and the safe start it leaves behind) before
// it starts.
//
// Not thread-safe: one thread drives a stage.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "core/error.h"
#include "drivers/rotary_stage.h"
#include "drivers/tic/stage_clock.h"
#include "drivers/tic/tic_protocol.h"
#include "drivers/tic/tic_transport.h"

namespace mesocap::drivers::tic {

struct TicStageOptions {
  std::string id = "tic";  // names the stage in messages ("turntable")
  std::string serial_number;
  TicProduct product = TicProduct::kT825;
  int full_steps_per_revolution = 200;  // of the motor
  // Microsteps per full step: a power of two the product offers (1-32;
  // T500 1-8; 36v4 1-256).
  int microsteps = 8;
  double gear_ratio = 1.0;           // motor turns per output turn
  double max_speed_rad_per_s = 0.5;  // of the output
  HomingDirection homing_direction = HomingDirection::kReverse;
  // The Tic's command timeout setting; 0 when it is off there.
  std::chrono::milliseconds command_timeout{kDefaultCommandTimeoutMs};
  // How often the stage resets the command timeout while it waits; at most
  // half of command_timeout, so one late poll does not stop the motor.
  std::chrono::milliseconds keepalive_period{kDefaultCommandTimeoutMs / 2};
  std::chrono::milliseconds poll_period{20};
  std::chrono::milliseconds homing_timeout{120000};
  // Slack on a move's motion time (and on a standing count) before the
  // stage calls it a stall.
  std::chrono::milliseconds stall_margin{500};

  core::CheckResult Check() const;
  // Microsteps per output revolution.
  double MicrostepsPerRevolution() const;
  // The Tic's max speed setting (microsteps per 10000 s) for max_speed_rad_per_s.
  double SpeedUnits() const;
};

class TicRotaryStage : public RotaryStage {
 public:
  // Opens the Tic through `opener` and sets its step mode and speed. Throws
  // core::Error when the options fail Check(), DeviceError when the Tic
  // cannot be opened or is another product than the options name.
  TicRotaryStage(TicStageOptions options, TicOpener opener, std::unique_ptr<StageClock> clock);

  std::string id() const override { return options_.id; }
  void Home() override;
  bool IsHomed() const override { return homed_; }
  void MoveTo(double angle_rad) override;
  void WaitUntilStopped(std::chrono::milliseconds timeout) override;
  bool IsMoving() const override;
  double Position() const override;

  // Opens the Tic again by serial number after a DisconnectedError and
  // sets it up again; the stage stays homed when the Tic kept its count.
  void Reopen();

  const TicStageOptions& options() const { return options_; }
  const TicDeviceInfo& device() const { return transport_->info(); }

 private:
  // Remembers the count while the Tic claims to move, to see it stand.
  struct StandingCount {
    std::int32_t position = 0;
    std::chrono::nanoseconds since{0};
  };

  void Configure();
  // One control transfer; errors name the stage.
  std::size_t Transfer(const ControlSetup& setup, std::span<std::uint8_t> data) const;
  TicVariables ReadVariables() const;
  void Send(const ControlSetup& setup) const;
  // Clears the command timeout and safe start an idle Tic collects; throws
  // DeviceError naming any other error, or when the position is uncertain
  // and `need_position`. Returns the variables after.
  TicVariables Prepare(bool need_position);
  void ThrowOnErrors(const TicVariables& variables);
  void ThrowIfStanding(const TicVariables& variables, StandingCount& standing);
  void KeepAliveAndSleep(std::chrono::nanoseconds deadline);
  double AngleOf(std::int32_t count) const;
  // How long a move of `microsteps` takes at the options' speed with the
  // Tic's acceleration and deceleration.
  double MotionSeconds(double microsteps, const TicVariables& variables) const;
  std::string Name() const;

  TicStageOptions options_;
  TicOpener opener_;
  std::unique_ptr<StageClock> clock_;
  std::unique_ptr<TicTransport> transport_;
  bool homed_ = false;
  bool move_pending_ = false;  // a MoveTo not yet waited for
  std::int32_t target_count_ = 0;
  std::chrono::nanoseconds move_due_{0};  // when the pending move should end
  std::chrono::nanoseconds last_keepalive_{0};
};

}  // namespace mesocap::drivers::tic
