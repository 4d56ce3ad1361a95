#include "acquisition/capture_station.h"

#include <cmath>
#include <exception>
#include <numbers>
#include <sstream>

namespace mesocap::acquisition {
namespace {

std::string StageState(const drivers::RotaryStage& stage) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(2);
  s << "at " << stage.Position() * 180.0 / std::numbers::pi << " deg" << (stage.IsHomed() ? ", homed" : ", not homed")
    << (stage.IsMoving() ? ", moving" : "");
  return s.str();
}

// A device that cannot be read is reported with its error, not skipped.
template <typename Read>
DeviceState Reading(std::string device, Read read) {
  try {
    return {std::move(device), read()};
  } catch (const std::exception& e) {
    return {std::move(device), std::string("error: ") + e.what()};
  }
}

}  // namespace

std::vector<DeviceState> ReadRigDeviceStates(const drivers::Rig& rig) {
  std::vector<DeviceState> states;
  for (const auto& camera : rig.cameras) {
    const drivers::CameraInfo info = camera->info();
    states.push_back(Reading("camera " + info.id, [&] {
      return info.model + ", " + std::to_string(info.sensor_width) + "x" + std::to_string(info.sensor_height) + ", " +
             std::to_string(info.bit_depth) + " bit";
    }));
  }
  if (rig.turntable) states.push_back(Reading("turntable", [&] { return StageState(*rig.turntable); }));
  if (rig.light_arc) states.push_back(Reading("light arc", [&] { return StageState(*rig.light_arc); }));
  if (rig.lamps) {
    states.push_back(Reading("lamps", [&] {
      int on = 0;
      for (int i = 0; i < rig.lamps->lamp_count(); ++i) on += rig.lamps->IsOn(i);
      return std::to_string(rig.lamps->lamp_count()) + " lamps, " + std::to_string(on) + " on";
    }));
  }
  if (rig.laser) {
    states.push_back(Reading("laser", [&] {
      return std::string(rig.laser->IsEnabled() ? "on" : "off") + ", mount " + std::to_string(rig.laser->mount()) +
             " of " + std::to_string(rig.laser->mount_count());
    }));
  }
  return states;
}

}  // namespace mesocap::acquisition
