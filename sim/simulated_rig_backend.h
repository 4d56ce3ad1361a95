// The "sim" rig backend: makes the simulated devices (sim/simulated_devices.h)
// for a rig description, all acting on one SimulatedRigState, rendering
// through the caller's FrameRenderer and failing as the FaultPlan says.
//
//   SimulatedRigBackend backend(renderer, FaultPlanOfRig(description), seed);
//   drivers::Rig rig = drivers::BuildRig(description, {{"sim", &backend}});
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "drivers/rig.h"
#include "sim/fault_plan.h"
#include "sim/simulated_devices.h"
#include "sim/simulated_rig_state.h"

namespace mesocap::sim {

class SimulatedRigBackend : public drivers::RigBackend {
 public:
  // Throws Error when `faults` fails FaultPlan::Check(). `renderer` must
  // outlive the cameras made here; the backend itself need not (see state()).
  // `seed` seeds the faults and the cameras' noise; `sensor` is every
  // camera's sensor model.
  explicit SimulatedRigBackend(FrameRenderer& renderer, FaultPlan faults = {}, std::uint64_t seed = 0,
                               SensorModel sensor = SensorModel::kNoisy);

  std::string name() const override { return "sim"; }
  // Each throws Error when the fault plan names a device `rig` lacks.
  std::unique_ptr<drivers::Camera> MakeCamera(const formats::RigDescription& rig, int camera_index) override;
  std::unique_ptr<drivers::RotaryStage> MakeTurntable(const formats::RigDescription& rig) override;
  std::unique_ptr<drivers::RotaryStage> MakeLightArc(const formats::RigDescription& rig) override;
  std::unique_ptr<drivers::LampBank> MakeLampBank(const formats::RigDescription& rig) override;
  std::unique_ptr<drivers::LaserUnit> MakeLaserUnit(const formats::RigDescription& rig) override;

  // Shared with every device made here (std::shared_ptr), so devices stay
  // valid when a Rig outlives the backend that built it, and a renderer or
  // test can read the state through the backend or keep it on its own.
  SimulatedRigState& state() { return *state_; }
  const SimulatedRigState& state() const { return *state_; }
  std::shared_ptr<SimulatedRigState> shared_state() const { return state_; }
  const FaultPlan& faults() const { return faults_; }
  std::uint64_t seed() const { return seed_; }

 private:
  void CheckFaultsAgainst(const formats::RigDescription& rig) const;

  std::shared_ptr<SimulatedRigState> state_;
  FrameRenderer& renderer_;
  FaultPlan faults_;
  std::uint64_t seed_;
  SensorModel sensor_;
};

}  // namespace mesocap::sim
