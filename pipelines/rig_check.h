// The preflight before a capture: opens every device of a rig through the
// backend its description names, reads its state, and reports each device
// as ok or with its error. Simulated devices are reported as such without
// opening (they need a scene).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/error.h"

namespace mesocap::pipelines {

struct RigCheckOptions {
  std::filesystem::path rig;  // a rig description file
  core::CheckResult Check() const;
};

struct DeviceCheck {
  std::string device;   // "camera cam0", "turntable", ...
  std::string backend;  // with its address: "aravis 127.0.0.1", "tic 00123456"
  bool ok = false;
  std::string state;  // what it read (ok) or the error (not ok)
};

std::vector<DeviceCheck> RunRigCheck(const RigCheckOptions& options);

// Every device the real backends find on this machine: GenICam cameras,
// Tic controllers, GPIO chips.
struct FoundDevice {
  std::string kind;  // "camera", "tic", "gpio chip"
  std::string id;
  std::string model;
  std::string serial;
  std::string address;
};
std::vector<FoundDevice> FindDevices();

}  // namespace mesocap::pipelines
