// Tics on this machine's USB, through libusb-1.0: enumeration by Pololu's
// vendor id and the Tic product ids, opening by serial number, and the
// control transfers of the Tic's native protocol.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "drivers/device_error.h"
#include "drivers/tic/tic_transport.h"

namespace mesocap::drivers::tic {

// The Tics plugged in now (an empty list when there are none, or no USB
// bus). Throws DeviceError when libusb cannot start.
std::vector<TicDeviceInfo> ListLibusbTics();

// Opens the Tic with this serial number. Throws DeviceError "no Tic with
// serial X found (found: ...)" naming the Tics there are, or "none".
std::unique_ptr<TicTransport> OpenLibusbTic(const std::string& serial_number);

// A TicOpener over OpenLibusbTic.
TicOpener LibusbTicOpener();

// The error a failed libusb call throws: DisconnectedError for
// LIBUSB_ERROR_NO_DEVICE, TimeoutError for LIBUSB_ERROR_TIMEOUT, DeviceError
// with libusb's description otherwise. `doing` says what failed.
[[noreturn]] void ThrowLibusbError(int libusb_error, const std::string& doing);

// The message when libusb_init fails (a container without /dev/bus/usb).
std::string LibusbStartFailure(int libusb_error);

}  // namespace mesocap::drivers::tic
