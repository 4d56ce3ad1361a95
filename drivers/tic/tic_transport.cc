#include "drivers/tic/tic_transport.h"

namespace mesocap::drivers::tic {

std::string Describe(const TicDeviceInfo& device) {
  std::string text = device.product_name + " ";
  text += device.serial_number.empty() ? "(serial unreadable: " + device.problem + ")" : device.serial_number;
  return text + " at " + device.bus_address;
}

}  // namespace mesocap::drivers::tic
