// The "gpiod" rig backend: the lamps and the laser unit on GPIO lines
// through libgpiod, as the rig description names them; the laser's tilt
// motor on a step/dir driver (GPIO) or on a Pololu Tic.
#pragma once

#include <memory>
#include <string>

#include "drivers/gpiod/gpio_line.h"
#include "drivers/rig.h"

namespace mesocap::drivers::gpiod {

GpioLineAddress LineAddress(const formats::GpioLineDescription& line);

class GpiodRigBackend : public RigBackend {
 public:
  // `open` opens chips by name: libgpiod's by default, an emulated chip in tests.
  explicit GpiodRigBackend(GpioChipOpener open = {});
  std::string name() const override { return "gpiod"; }
  std::unique_ptr<LampBank> MakeLampBank(const formats::RigDescription& rig) override;
  std::unique_ptr<LaserUnit> MakeLaserUnit(const formats::RigDescription& rig) override;

 private:
  GpioChipOpener open_;
};

}  // namespace mesocap::drivers::gpiod
