#include "pipelines/rig_check.h"

#include <functional>

#include "drivers/aravis/aravis_rig_backend.h"
#include "drivers/aravis/camera_discovery.h"
#include "drivers/device_state.h"
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

DeviceCheck Probe(std::string device, std::string backend, const std::function<std::string()>& read) {
  drivers::DeviceState s = drivers::ReadDeviceState(std::move(device), "", read);
  return {std::move(s.device), std::move(backend), s.ok, std::move(s.state)};
}

}  // namespace

core::CheckResult RigCheckOptions::Check() const { return rig.empty() ? "rig: expected a rig description file" : ""; }

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
    checks.push_back(Probe("camera " + c.id, "aravis " + c.device,
                           [&] { return drivers::DescribeCamera(*aravis.MakeCamera(rig, i)); }));
  }
  const std::pair<const char*, const formats::StageDescription*> stages[] = {{"turntable", &rig.turntable},
                                                                             {"light arc", &rig.light_arc}};
  for (const auto& [name, stage] : stages) {
    if (stage->backend != "tic") {
      checks.push_back({name, stage->backend, true, simulated});
      continue;
    }
    checks.push_back(Probe(name, "tic " + stage->tic.serial, [&, name = std::string(name)] {
      return drivers::DescribeStage(*(name == "turntable" ? tic.MakeTurntable(rig) : tic.MakeLightArc(rig)));
    }));
  }
  if (rig.lamps.backend != "gpiod") {
    checks.push_back({"lamps", rig.lamps.backend, true, simulated});
  } else {
    checks.push_back(Probe("lamps", "gpiod " + GpioLine(rig.lamps.lines.front()),
                           [&] { return drivers::DescribeLamps(*gpiod.MakeLampBank(rig)); }));
  }
  if (rig.laser.backend != "gpiod") {
    checks.push_back({"laser unit", rig.laser.backend, true, simulated});
  } else {
    checks.push_back(Probe("laser unit", "gpiod " + GpioLine(rig.laser.enable),
                           [&] { return drivers::DescribeLaser(*gpiod.MakeLaserUnit(rig)); }));
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
