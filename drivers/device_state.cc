#include "drivers/device_state.h"

#include <sstream>

#include "core/angles.h"
#include "drivers/device_error.h"

namespace mesocap::drivers {

DeviceState ReadDeviceState(std::string device, std::string kind, const std::function<std::string()>& describe) {
  DeviceState s{std::move(device), std::move(kind), false, ""};
  try {
    s.state = describe();
    s.ok = true;
  } catch (const std::exception& e) {
    s.state = e.what();
  }
  return s;
}

std::string DescribeCamera(Camera& camera) {
  const CameraInfo info = camera.info();
  if (!camera.IsConnected()) throw DisconnectedError("camera " + info.id + ": disconnected (it does not answer)");
  std::ostringstream s;
  if (!info.model.empty()) s << info.model << ", ";
  s << info.sensor_width << " x " << info.sensor_height << ", " << info.bit_depth << " bits, " << info.channels
    << (info.channels == 1 ? " channel" : " channels");
  return s.str();
}

std::string DescribeStage(const RotaryStage& stage) {
  std::ostringstream s;
  s << "at " << core::DegreesFromRadians(stage.Position()) << " deg, " << (stage.IsHomed() ? "homed" : "not homed");
  if (stage.IsMoving()) s << ", moving";
  return s.str();
}

std::string DescribeLamps(const LampBank& lamps) {
  std::string on;
  for (int i = 0; i < lamps.lamp_count(); ++i) {
    if (lamps.IsOn(i)) on += (on.empty() ? "" : ", ") + std::to_string(i);
  }
  return std::to_string(lamps.lamp_count()) + " lamps, " + (on.empty() ? "all off" : "on: " + on);
}

std::string DescribeLaser(const LaserUnit& laser) {
  std::ostringstream s;
  s << (laser.IsEnabled() ? "on" : "off") << ", mount " << laser.mount() << " of " << laser.mount_count() << ", tilt "
    << core::DegreesFromRadians(laser.Tilt()) << " deg";
  return s.str();
}

std::vector<DeviceState> ReadDeviceStates(Rig& rig) {
  std::vector<DeviceState> states;
  for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
    const std::string id = i < rig.description.cameras.size() ? rig.description.cameras[i].id : std::to_string(i);
    states.push_back(ReadDeviceState("camera " + id, "camera", [&] { return DescribeCamera(*rig.cameras[i]); }));
  }
  if (rig.turntable)
    states.push_back(ReadDeviceState("turntable", "stage", [&] { return DescribeStage(*rig.turntable); }));
  if (rig.light_arc)
    states.push_back(ReadDeviceState("light arc", "stage", [&] { return DescribeStage(*rig.light_arc); }));
  if (rig.lamps) states.push_back(ReadDeviceState("lamps", "lamps", [&] { return DescribeLamps(*rig.lamps); }));
  if (rig.laser) states.push_back(ReadDeviceState("laser unit", "laser", [&] { return DescribeLaser(*rig.laser); }));
  return states;
}

}  // namespace mesocap::drivers
