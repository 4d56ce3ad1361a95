// The laser scan unit with its emitter switched by a GPIO line (the enable
// input of the laser module's driver) and its tilt motor behind any rotary
// stage: a StepDirStepper on GPIO lines, or a stage on its own controller.
#pragma once

#include <chrono>
#include <memory>
#include <string>

#include "core/error.h"
#include "drivers/gpiod/gpio_line.h"
#include "drivers/laser_unit.h"
#include "drivers/rotary_stage.h"

namespace mesocap::drivers::gpiod {

struct GpioLaserOptions {
  GpioLineAddress enable;  // active: the laser emits
  // The tilt either way from the calibrated plane that the mechanics allow.
  double max_tilt_rad = 0.7853981633974483;  // 45 degrees
  int mount_count = 1;                       // mounts on the light arc
  int mount = 0;                             // where the operator put it

  core::CheckResult Check() const;
};

// Tilt 0 is the tilt stage's position 0 (its reference); negative tilts are
// the angles just below a full turn. The stage is homed on the first SetTilt.
// The laser is off once built and when destroyed.
class GpioLaserUnit : public LaserUnit {
 public:
  // Throws DeviceError for options that fail Check(), no tilt stage, or a
  // line that cannot be requested.
  GpioLaserUnit(GpioLaserOptions options, const GpioChipOpener& open, std::unique_ptr<RotaryStage> tilt);
  ~GpioLaserUnit() override;

  void SetEnabled(bool on) override;
  bool IsEnabled() const override { return enabled_; }
  // DeviceError beyond +-max_tilt_rad; the stage's TimeoutError / StallError.
  void SetTilt(double tilt_rad, std::chrono::milliseconds timeout) override;
  double Tilt() const override;
  int mount_count() const override { return options_.mount_count; }
  int mount() const override { return mount_; }
  void SetMount(int mount) override;

 private:
  GpioLaserOptions options_;
  std::unique_ptr<GpioOutputLine> enable_;
  std::unique_ptr<RotaryStage> tilt_;
  bool enabled_ = false;
  int mount_;
};

}  // namespace mesocap::drivers::gpiod
