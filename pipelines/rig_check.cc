#include "pipelines/rig_check.h"

#include <functional>
#include <sstream>

#include "core/angles.h"
#include "drivers/aravis/aravis_rig_backend.h"
#include "drivers/aravis/camera_discovery.h"
#include "drivers/gpiod/gpiod_rig_backend.h"
#include "drivers/gpiod/libgpiod_chip.h"
#include "drivers/tic/libusb_tic_transport.h"
#include "drivers/tic/tic_rig_backend.h"
#include "formats/rig_description.h"

namespace mesocap::pipelines {
namespace {

std::string GpioLine(const formats::GpioLineDescription& l) {
  return l.chip + " line " + (l.name.empty() ? std::to_string(l.offset) : l.name);
}

// Runs `read` and records its state, or the error it threw.
DeviceCheck Probe(std::string device, std::string backend, const std::function<std::string()>& read) {
  DeviceCheck c{std::move(device), std::move(backend), false, ""};
  try {
    c.state = read();
    c.ok = true;
  } catch (const std::exception& e) {
    c.state = e.what();
  }
  return c;
}

std::string StageState(drivers::RotaryStage& stage) {
  std::ostringstream s;
  s << "at " << core::DegreesFromRadians(stage.Position()) << " deg, " << (stage.IsHomed() ? "homed" : "not homed");
  return s.str();
}

}  // namespace

std::string RigCheckOptions::Check() const { return rig.empty() ? "rig: expected a rig description file" : ""; }

std::vector<DeviceCheck> RunRigCheck(const RigCheckOptions& options) {
  const formats::RigDescription rig = formats::ReadRigDescription(options.rig);
  drivers::aravis::AravisRigBackend aravis;
  drivers::tic::TicRigBackend tic;
  drivers::gpiod::GpiodRigBackend gpiod;
  std::vector<DeviceCheck> checks;
  const std::string simulated = "simulated (opened with a scene by mesocap simulate)";
  for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i) {
    const auto& c = rig.cameras[i];
    if (c.backend != "aravis") {
      checks.push_back({"camera " + c.id, c.backend, true, simulated});
      continue;
    }
    checks.push_back(Probe("camera " + c.id, "aravis " + c.device, [&] {
      const auto camera = aravis.MakeCamera(rig, i);
      const auto info = camera->info();
      return info.model + ", " + std::to_string(info.sensor_width) + " x " + std::to_string(info.sensor_height) +
             ", " + std::to_string(info.bit_depth) + " bits, " + std::to_string(info.channels) + " channels";
    }));
  }
  const std::pair<const char*, const formats::StageDescription*> stages[] = {{"turntable", &rig.turntable},
                                                                             {"light arc", &rig.light_arc}};
  for (const auto& [name, stage] : stages) {
    if (stage->backend != "tic") {
      checks.push_back({name, stage->backend, true, simulated});
      continue;
    }
    checks.push_back(Probe(name, "tic " + stage->tic.serial, [&, name = std::string(name)] {
      auto s = name == "turntable" ? tic.MakeTurntable(rig) : tic.MakeLightArc(rig);
      return StageState(*s);
    }));
  }
  if (rig.lamps.backend != "gpiod") {
    checks.push_back({"lamps", rig.lamps.backend, true, simulated});
  } else {
    checks.push_back(Probe("lamps", "gpiod " + GpioLine(rig.lamps.lines.front()), [&] {
      const auto lamps = gpiod.MakeLampBank(rig);
      return std::to_string(lamps->lamp_count()) + " lamps, all off";
    }));
  }
  if (rig.laser.backend != "gpiod") {
    checks.push_back({"laser unit", rig.laser.backend, true, simulated});
  } else {
    checks.push_back(Probe("laser unit", "gpiod " + GpioLine(rig.laser.enable), [&] {
      const auto laser = gpiod.MakeLaserUnit(rig);
      std::ostringstream s;
      s << "off, tilt " << core::DegreesFromRadians(laser->Tilt()) << " deg";
      return s.str();
    }));
  }
  return checks;
}

std::vector<FoundDevice> FindDevices() {
  std::vector<FoundDevice> found;
  for (const auto& c : drivers::aravis::DiscoverCameras()) {
    found.push_back({"camera", c.id, c.vendor + " " + c.model, c.serial, c.protocol + " " + c.address});
  }
  for (const auto& t : drivers::tic::ListLibusbTics()) {
    found.push_back({"tic", t.serial_number, t.product_name, t.serial_number, "USB " + t.bus_address});
  }
  for (const auto& chip : drivers::gpiod::ListLibgpiodChips()) found.push_back({"gpio chip", chip, "", "", ""});
  return found;
}

}  // namespace mesocap::pipelines
