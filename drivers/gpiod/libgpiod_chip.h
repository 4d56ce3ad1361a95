// The kernel's GPIO lines through libgpiod 1.6's C++ bindings (gpiod.hpp).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "drivers/gpiod/gpio_line.h"

namespace mesocap::drivers::gpiod {

// Opens a chip by name ("gpiochip0"), path ("/dev/gpiochip0"), label or
// number. Throws DeviceError naming the chip, why, and the chips there are:
// `GPIO chip "gpiochip0": cannot open: No such file or directory; chips
// here: none`. Its lines report a line in use with the consumer holding it,
// and a chip that went away as DisconnectedError.
std::unique_ptr<GpioChip> OpenLibgpiodChip(const std::string& chip);

// OpenLibgpiodChip as the devices take it.
GpioChipOpener LibgpiodChipOpener();

// The chips this machine has, as "gpiochip0 [pinctrl-bcm2711]".
std::vector<std::string> ListLibgpiodChips();

}  // namespace mesocap::drivers::gpiod
