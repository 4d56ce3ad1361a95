#include "drivers/gpiod/gpiod_rig_backend.h"

#include "drivers/gpiod/gpio_lamp_bank.h"
#include "drivers/gpiod/gpio_laser_unit.h"
#include "drivers/gpiod/libgpiod_chip.h"
#include "drivers/gpiod/step_dir_stepper.h"
#include "drivers/tic/tic_rig_backend.h"

namespace mesocap::drivers::gpiod {

GpioLineAddress LineAddress(const formats::GpioLineDescription& line) {
  GpioLineAddress a;
  a.chip = line.chip;
  a.offset = line.offset;
  a.name = line.name;
  a.active_low = line.active_low;
  return a;
}

GpiodRigBackend::GpiodRigBackend(GpioChipOpener open) : open_(open ? std::move(open) : LibgpiodChipOpener()) {}

std::unique_ptr<LampBank> GpiodRigBackend::MakeLampBank(const formats::RigDescription& rig) {
  GpioLampBankOptions options;
  for (std::size_t i = 0; i < rig.lamps.lines.size(); ++i) {
    GpioLamp lamp;
    lamp.power = LineAddress(rig.lamps.lines[i]);
    if (i < rig.lamps.sense_lines.size()) lamp.sense = LineAddress(rig.lamps.sense_lines[i]);
    options.lamps.push_back(lamp);
  }
  options.settle = std::chrono::milliseconds(static_cast<long>(rig.lamps.settle_ms));
  return std::make_unique<GpioLampBank>(options, open_);
}

std::unique_ptr<LaserUnit> GpiodRigBackend::MakeLaserUnit(const formats::RigDescription& rig) {
  const auto& l = rig.laser;
  // The tilt turns slowly: a sweep steps it a frame at a time.
  constexpr double kTiltSpeedRadPerS = 0.5;
  std::unique_ptr<RotaryStage> tilt;
  if (l.tilt_backend == "tic") {
    tilt = tic::OpenTicStage("laser tilt", l.tilt_tic, kTiltSpeedRadPerS);
  } else {
    StepDirStepperOptions o;
    o.id = "laser tilt";
    o.step = LineAddress(l.tilt_stepper.step);
    o.direction = LineAddress(l.tilt_stepper.direction);
    o.limit_switch = LineAddress(l.tilt_stepper.limit_switch);
    o.full_steps_per_revolution = l.tilt_stepper.full_steps_per_revolution;
    o.microsteps = l.tilt_stepper.microsteps;
    o.gear_ratio = l.tilt_stepper.gear_ratio;
    o.max_speed_rad_per_s = kTiltSpeedRadPerS;
    o.home_towards_positive = l.tilt_stepper.home_forward;
    tilt = std::make_unique<StepDirStepper>(o, open_);
  }
  GpioLaserOptions options;
  options.enable = LineAddress(l.enable);
  options.mount_count = static_cast<int>(l.mount_elevations_rad.size());
  return std::make_unique<GpioLaserUnit>(options, open_, std::move(tilt));
}

}  // namespace mesocap::drivers::gpiod
