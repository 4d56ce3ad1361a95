// A rig's cameras served as GigE Vision devices on local addresses, through
// Aravis' fake GigE Vision camera: GVCP control and GVSP streaming on the
// real protocol, so any GenICam client (mesocap's Aravis backend,
// arv-tool-0.8, arv-viewer-0.8) can connect. Each frame a served camera
// sends is one Grab of the camera behind it, made with the exposure, gain,
// region, pixel format the client set; a simulated camera behind it renders
// the shared rig state, so stages, lamps and laser driven in this process
// show in the served frames. A triggered frame is rendered on a thread of
// the server's own, so the device answers its control channel while a
// frame takes seconds to render.
//
// The served device offers the pixel formats of the camera behind it: Mono
// and RGB at its bit depth (Mono12 and RGB12 for a 12-bit sensor), with
// codes round(value * (2^bits - 1)): a simulated frame crosses the network
// without a bit changing. GainRaw is the gain in dB.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "drivers/camera.h"
#include "formats/rig_description.h"

namespace mesocap::sim {

class SimulatedRigBackend;

struct ServedCameraAddress {
  std::string address;  // IPv4 address of a local interface (GVCP port 3956)
  std::string serial;   // GigE Vision serial number, at most 15 characters
};

// Where each of a rig's cameras is served: an "aravis" camera at its
// device when that is an IPv4 address, the others at 127.0.0.<index + 1>;
// the serial is the camera id. Throws Error for an id too long to be a
// serial.
std::vector<ServedCameraAddress> ServedAddresses(const formats::RigDescription& rig);

class ServedCameras {
 public:
  // Starts one GigE Vision device per camera. Throws Error naming the
  // address when one cannot be served (not an address of this host's
  // interfaces, or its port is taken); nothing stays served then.
  // `scene_changes`, when given, counts the changes to what the cameras
  // image (SimulatedRigState::changes): a camera triggered again with no
  // change and the same settings sends its last frame again rather than a
  // new exposure.
  ServedCameras(std::vector<std::unique_ptr<drivers::Camera>> cameras, std::vector<ServedCameraAddress> addresses,
                std::function<std::uint64_t()> scene_changes = {});
  // Stops serving: clients lose their control channel.
  ~ServedCameras();
  ServedCameras(const ServedCameras&) = delete;
  ServedCameras& operator=(const ServedCameras&) = delete;

  std::size_t size() const { return servers_.size(); }
  // Stops serving camera i, as a camera unplugged or a killed server:
  // clients lose its control channel. ServeAgain starts it again at the
  // same address, its registers as after power-on (a client reopens it).
  void StopServing(std::size_t i);
  void ServeAgain(std::size_t i);
  const ServedCameraAddress& address(std::size_t i) const;
  // Frames sent, and frames whose Grab failed (sent black) by camera.
  std::uint64_t frames_served(std::size_t i) const;
  std::uint64_t frames_failed(std::size_t i) const;

 private:
  struct Server;
  void Serve(std::size_t i);

  // The cameras behind the servers share one rig state: one renders at a time.
  std::mutex render_mutex_;
  std::vector<std::unique_ptr<Server>> servers_;
};

// Serves every camera of `rig` as the simulated rig's backend makes it
// (sharing its state, seed and faults), at ServedAddresses(rig).
std::unique_ptr<ServedCameras> ServeRigCameras(const formats::RigDescription& rig, SimulatedRigBackend& backend);

}  // namespace mesocap::sim
