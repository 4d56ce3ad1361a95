// Owning handles of Embree's device and scene, released with Embree's own
// calls, for the simulator's ray-cast scenes.
#pragma once

#include <embree3/rtcore.h>

#include <memory>
#include <type_traits>

namespace mesocap::sim {

struct EmbreeDeviceRelease {
  void operator()(RTCDevice device) const { rtcReleaseDevice(device); }
};
struct EmbreeSceneRelease {
  void operator()(RTCScene scene) const { rtcReleaseScene(scene); }
};
using EmbreeDevice = std::unique_ptr<std::remove_pointer_t<RTCDevice>, EmbreeDeviceRelease>;
using EmbreeScene = std::unique_ptr<std::remove_pointer_t<RTCScene>, EmbreeSceneRelease>;

}  // namespace mesocap::sim
