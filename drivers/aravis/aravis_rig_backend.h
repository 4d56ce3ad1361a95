// The "aravis" rig backend: the cameras a rig description names with
// "backend": "aravis" and a "device" (id, serial number or address).
#pragma once

#include <memory>
#include <string>

#include "drivers/aravis/stream_ports.h"
#include "drivers/rig.h"

namespace mesocap::drivers::aravis {

class AravisRigBackend : public RigBackend {
 public:
  std::string name() const override { return "aravis"; }
  std::unique_ptr<Camera> MakeCamera(const formats::RigDescription& rig, int camera_index) override;

 private:
  // Shared by the cameras it makes: their streams' ports.
  std::shared_ptr<StreamPorts> stream_ports_ = std::make_shared<StreamPorts>();
};

// Reopens each of `rig`'s Aravis cameras that no longer answers (unplugged,
// powered off, its server killed), when it answers again; a camera still
// gone stays as it is. For between steps, never during one.
void ReopenGoneCameras(Rig& rig);

}  // namespace mesocap::drivers::aravis
