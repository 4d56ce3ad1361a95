// What a rig's devices report right now, one line each: the preflight's
// check (`mesocap rig check`) and the capture daemon's rig status read the
// same. Reading a state asks the device (a camera's info, a stage's
// position), so a device that is gone shows here as not ok with its error.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "drivers/rig.h"

namespace mesocap::drivers {

struct DeviceState {
  std::string device;  // "camera cam0", "turntable", "light arc", "lamps", "laser unit"
  std::string kind;    // "camera", "stage", "lamps", "laser"
  bool ok = false;
  std::string state;  // what it read (ok), or the error (not ok)
};

// "1280 x 960, 12 bits, 3 channels" and the like. Each throws the device's
// error; DescribeCamera asks the camera (Camera::IsConnected) and throws
// DisconnectedError when it is gone.
std::string DescribeCamera(Camera& camera);
std::string DescribeStage(const RotaryStage& stage);
std::string DescribeLamps(const LampBank& lamps);
std::string DescribeLaser(const LaserUnit& laser);

// Runs `describe` and records its text, or the error it threw, as the state.
DeviceState ReadDeviceState(std::string device, std::string kind, const std::function<std::string()>& describe);

// Every device of `rig`, cameras first in description order. Never throws
// for a device's failure: that device is reported not ok.
std::vector<DeviceState> ReadDeviceStates(Rig& rig);

}  // namespace mesocap::drivers
