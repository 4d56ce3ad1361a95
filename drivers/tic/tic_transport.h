// The seam between a Tic stage and the USB: one control transfer at a time.
// The production transport is libusb (libusb_tic_transport.h); tests use an
// emulated Tic (emulated_tic.h) that answers the same transfers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>

#include "drivers/tic/tic_protocol.h"

namespace mesocap::drivers::tic {

// A Tic found on the bus.
struct TicDeviceInfo {
  std::string serial_number;  // "" when it could not be read (see problem)
  TicProduct product = TicProduct::kT825;
  std::string product_name;
  std::string bus_address;  // "bus 1 address 7"
  std::string problem;      // why the serial number could not be read; "" when it was
};

// "Tic T825 Stepper Motor Controller 00123456 at bus 1 address 7".
std::string Describe(const TicDeviceInfo& device);

class TicTransport {
 public:
  virtual ~TicTransport() = default;
  virtual const TicDeviceInfo& info() const = 0;
  // Runs one control transfer. A device-to-host transfer fills `data` (at
  // least setup.length bytes); a host-to-device one sends setup.length bytes
  // of it. Returns the bytes transferred. Throws DisconnectedError when the
  // device is gone (it must be reopened), TimeoutError when it did not
  // answer in time, DeviceError when it rejected the request.
  virtual std::size_t ControlTransfer(const ControlSetup& setup, std::span<std::uint8_t> data) = 0;
};

// Opens the Tic with a serial number; throws DeviceError naming the serial
// (and the Tics there are) when there is none. A stage keeps one to reopen
// its Tic after an unplug.
using TicOpener = std::function<std::unique_ptr<TicTransport>(const std::string& serial_number)>;

}  // namespace mesocap::drivers::tic
