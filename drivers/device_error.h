// Typed device failures, so the capture daemon can tell a retryable timeout
// from a disconnect or a stall that needs the operator.
#pragma once

#include <string>

#include "core/error.h"

namespace mesocap::drivers {

// Base of every device failure; the message names the device ("camera cam3").
class DeviceError : public core::Error {
 public:
  using core::Error::Error;
};

// The device did not answer in time; retrying may succeed.
class TimeoutError : public DeviceError {
 public:
  using DeviceError::DeviceError;
};

// The device is gone (cable, power); it must be reopened.
class DisconnectedError : public DeviceError {
 public:
  using DeviceError::DeviceError;
};

// A stage did not reach its target (a stepper lost steps or hit an obstacle);
// its position is unknown until it is homed again.
class StallError : public DeviceError {
 public:
  using DeviceError::DeviceError;
};

// A lamp did not light (burnt out); the lamp's images cannot be taken.
class LampFailureError : public DeviceError {
 public:
  using DeviceError::DeviceError;
};

}  // namespace mesocap::drivers
