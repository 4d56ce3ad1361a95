// A capture rig: the devices of the MDF paper's BTF-MDF measurement system
// (Sec. 3.1), each behind its interface and owned by the Rig. Which
// implementation drives each device is named per device in the rig
// description ("backend": "sim" now; real backends later), and the caller
// supplies the backends: drivers/ knows no implementation, so no globals.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "drivers/camera.h"
#include "drivers/lamp_bank.h"
#include "drivers/laser_unit.h"
#include "drivers/rotary_stage.h"
#include "formats/rig_description.h"

namespace mesocap::drivers {

struct Rig {
  formats::RigDescription description;
  std::vector<std::unique_ptr<Camera>> cameras;  // in description order
  std::unique_ptr<RotaryStage> turntable;
  std::unique_ptr<RotaryStage> light_arc;
  std::unique_ptr<LampBank> lamps;
  std::unique_ptr<LaserUnit> laser;
};

// Makes devices of one kind of backend. A backend may make only some kinds;
// the defaults throw DeviceError naming what it cannot make.
class RigBackend {
 public:
  virtual ~RigBackend() = default;
  virtual std::string name() const = 0;
  virtual std::unique_ptr<Camera> MakeCamera(const formats::RigDescription& rig, int camera_index);
  virtual std::unique_ptr<RotaryStage> MakeTurntable(const formats::RigDescription& rig);
  virtual std::unique_ptr<RotaryStage> MakeLightArc(const formats::RigDescription& rig);
  virtual std::unique_ptr<LampBank> MakeLampBank(const formats::RigDescription& rig);
  virtual std::unique_ptr<LaserUnit> MakeLaserUnit(const formats::RigDescription& rig);
};

// Builds every device with the backend its description names. Throws Error
// naming the device when its backend is not among `backends`.
Rig BuildRig(const formats::RigDescription& description, const std::map<std::string, RigBackend*>& backends);

}  // namespace mesocap::drivers
