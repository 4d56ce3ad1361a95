#include "drivers/rig.h"

#include "core/error.h"
#include "drivers/device_error.h"

namespace mesocap::drivers {
namespace {

[[noreturn]] void CannotMake(const RigBackend& backend, const std::string& what) {
  throw DeviceError("backend " + core::Quoted(backend.name()) + " cannot drive the " + what);
}

RigBackend& Find(const std::map<std::string, RigBackend*>& backends, const std::string& name,
                 const std::string& device) {
  auto it = backends.find(name);
  if (it == backends.end() || it->second == nullptr) {
    std::string known;
    for (const auto& [n, b] : backends) known += (known.empty() ? "" : ", ") + n;
    throw core::Error(device + ": backend " + core::Quoted(name) +
                      " is not available in this program (available: " + (known.empty() ? "none" : known) + ")");
  }
  return *it->second;
}

}  // namespace

std::unique_ptr<Camera> RigBackend::MakeCamera(const formats::RigDescription&, int) { CannotMake(*this, "cameras"); }
std::unique_ptr<RotaryStage> RigBackend::MakeTurntable(const formats::RigDescription&) {
  CannotMake(*this, "turntable");
}
std::unique_ptr<RotaryStage> RigBackend::MakeLightArc(const formats::RigDescription&) {
  CannotMake(*this, "light arc");
}
std::unique_ptr<LampBank> RigBackend::MakeLampBank(const formats::RigDescription&) { CannotMake(*this, "lamps"); }
std::unique_ptr<LaserUnit> RigBackend::MakeLaserUnit(const formats::RigDescription&) {
  CannotMake(*this, "laser unit");
}

Rig BuildRig(const formats::RigDescription& d, const std::map<std::string, RigBackend*>& backends) {
  Rig rig;
  rig.description = d;
  for (int i = 0; i < static_cast<int>(d.cameras.size()); ++i) {
    const auto& cam = d.cameras[i];
    rig.cameras.push_back(Find(backends, cam.backend, "camera " + cam.id).MakeCamera(d, i));
  }
  rig.turntable = Find(backends, d.turntable.backend, "turntable").MakeTurntable(d);
  rig.light_arc = Find(backends, d.light_arc.backend, "light arc").MakeLightArc(d);
  rig.lamps = Find(backends, d.lamps.backend, "lamps").MakeLampBank(d);
  rig.laser = Find(backends, d.laser.backend, "laser unit").MakeLaserUnit(d);
  return rig;
}

}  // namespace mesocap::drivers
