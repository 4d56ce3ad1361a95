// A motorized rotation stage: the turntable carrying the sample, and the
// light arc rotating in azimuth (MDF paper Sec. 3.1: both driven by steppers).
#pragma once

#include <chrono>
#include <string>

namespace mesocap::drivers {

class RotaryStage {
 public:
  virtual ~RotaryStage() = default;

  virtual std::string id() const = 0;
  // Finds the reference switch and sets the position to 0. Throws
  // TimeoutError / StallError / DisconnectedError.
  virtual void Home() = 0;
  virtual bool IsHomed() const = 0;
  // Starts a move to an absolute angle (radians, in [0, 2 pi); the stage
  // takes the shorter way). Throws DeviceError when not homed.
  virtual void MoveTo(double angle_rad) = 0;
  // Blocks until the stage stops at its target. Throws TimeoutError when it
  // is still moving after `timeout`, StallError when it stopped elsewhere.
  virtual void WaitUntilStopped(std::chrono::milliseconds timeout) = 0;
  virtual bool IsMoving() const = 0;
  // Current angle (radians), as the controller counts it.
  virtual double Position() const = 0;
};

}  // namespace mesocap::drivers
