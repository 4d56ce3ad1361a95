#include "drivers/aravis/camera_discovery.h"

#include <arpa/inet.h>
#include <arv.h>

#include <mutex>

#include "core/error.h"
#include "drivers/device_error.h"

namespace mesocap::drivers::aravis {
namespace {

std::string Text(const char* s) { return s ? s : ""; }

// Aravis keeps one device list for the process; refresh and read it as one.
std::mutex& DeviceListMutex() {
  static std::mutex mutex;
  return mutex;
}

bool IsIpv4Address(const std::string& s) {
  in_addr address{};
  return inet_pton(AF_INET, s.c_str(), &address) == 1;
}

}  // namespace

std::vector<DiscoveredCamera> DiscoverCameras() {
  std::lock_guard lock(DeviceListMutex());
  arv_update_device_list();
  std::vector<DiscoveredCamera> cameras;
  const unsigned n = arv_get_n_devices();
  for (unsigned i = 0; i < n; ++i) {
    cameras.push_back({Text(arv_get_device_id(i)), Text(arv_get_device_vendor(i)), Text(arv_get_device_model(i)),
                       Text(arv_get_device_serial_nbr(i)), Text(arv_get_device_address(i)),
                       Text(arv_get_device_protocol(i))});
  }
  return cameras;
}

std::string ResolveCamera(const std::string& device) {
  if (IsIpv4Address(device)) return device;
  const auto cameras = DiscoverCameras();
  std::vector<const DiscoveredCamera*> matches;
  for (const auto& c : cameras) {
    if (c.id == device || c.serial == device || c.address == device) matches.push_back(&c);
  }
  if (matches.size() == 1) return matches.front()->id;
  std::string found;
  for (const auto& c : cameras) found += (found.empty() ? "" : ", ") + c.id + " (" + c.address + ")";
  if (matches.empty()) {
    throw DeviceError("no camera " + core::Quoted(device) + " found (found: " + (found.empty() ? "none" : found) + ")");
  }
  throw DeviceError("camera " + core::Quoted(device) + " is ambiguous (found: " + found +
                    "); name it by its device id");
}

void ReleaseDiscovery() { arv_shutdown(); }

}  // namespace mesocap::drivers::aravis
