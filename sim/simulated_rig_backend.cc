#include "sim/simulated_rig_backend.h"

#include "core/error.h"
#include "sim/simulated_devices.h"

namespace mesocap::sim {

SimulatedRigBackend::SimulatedRigBackend(FrameRenderer& renderer, FaultPlan faults, std::uint64_t seed,
                                         SensorModel sensor)
    : state_(std::make_shared<SimulatedRigState>()),
      renderer_(renderer),
      faults_(std::move(faults)),
      seed_(seed),
      sensor_(sensor) {
  core::ThrowIfInvalid(faults_.Check(), "simulated rig");
}

void SimulatedRigBackend::CheckFaultsAgainst(const formats::RigDescription& rig) const {
  core::ThrowIfInvalid(faults_.Check(rig), "simulated rig");
}

std::unique_ptr<drivers::Camera> SimulatedRigBackend::MakeCamera(const formats::RigDescription& rig, int camera_index) {
  CheckFaultsAgainst(rig);
  if (camera_index < 0 || camera_index >= static_cast<int>(rig.cameras.size())) {
    throw core::Error("simulated rig: no camera " + std::to_string(camera_index) + " in rig " + core::Quoted(rig.name));
  }
  return std::make_unique<SimulatedCamera>(rig, camera_index, state_, renderer_, faults_, seed_, sensor_);
}

// The two stages are one class; which state angle each drives follows from
// which virtual BuildRig calls.
std::unique_ptr<drivers::RotaryStage> SimulatedRigBackend::MakeTurntable(const formats::RigDescription& rig) {
  CheckFaultsAgainst(rig);
  return std::make_unique<SimulatedRotaryStage>(rig, SimulatedRotaryStage::Axis::kTurntable, state_, faults_, seed_);
}

std::unique_ptr<drivers::RotaryStage> SimulatedRigBackend::MakeLightArc(const formats::RigDescription& rig) {
  CheckFaultsAgainst(rig);
  return std::make_unique<SimulatedRotaryStage>(rig, SimulatedRotaryStage::Axis::kLightArc, state_, faults_, seed_);
}

std::unique_ptr<drivers::LampBank> SimulatedRigBackend::MakeLampBank(const formats::RigDescription& rig) {
  CheckFaultsAgainst(rig);
  return std::make_unique<SimulatedLampBank>(rig, state_, faults_, seed_);
}

std::unique_ptr<drivers::LaserUnit> SimulatedRigBackend::MakeLaserUnit(const formats::RigDescription& rig) {
  CheckFaultsAgainst(rig);
  return std::make_unique<SimulatedLaserUnit>(rig, state_);
}

}  // namespace mesocap::sim
