// Finding GenICam cameras (GigE Vision and USB3 Vision) through Aravis.
#pragma once

#include <string>
#include <vector>

namespace mesocap::drivers::aravis {

struct DiscoveredCamera {
  std::string id;  // Aravis device id ("Vendor-Model-Serial"), opens the camera
  std::string vendor;
  std::string model;
  std::string serial;
  std::string address;   // IPv4 address (GigE Vision) or USB bus address
  std::string protocol;  // "GigEVision" or "USB3Vision"
};

// Every camera that answers discovery on this machine's interfaces now
// (loopback included).
std::vector<DiscoveredCamera> DiscoverCameras();

// The Aravis device id that `device` names, given as an id, a serial number
// or an address. An IPv4 address is returned as given (Aravis opens it
// directly, without discovery). Throws DeviceError listing what was found
// when nothing matches, or when `device` matches several cameras.
std::string ResolveCamera(const std::string& device);

// Aravis keeps its interfaces' discovery sockets from one discovery to the
// next, for the life of the process; this closes them (arv_shutdown), for a
// long-running program done with its cameras and for tests that check
// nothing is left open. A later discovery opens them again.
void ReleaseDiscovery();

}  // namespace mesocap::drivers::aravis
