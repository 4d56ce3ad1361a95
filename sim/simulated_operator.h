// The operator of the simulated rig (drivers/rig_operator.h): lays the
// calibration plate and the white reference and sets the calibration board
// into the simulated state and moves the laser unit by hand, instantly
// (simulated time does not model the person).
#pragma once

#include <memory>

#include "drivers/rig_operator.h"
#include "sim/simulated_rig_state.h"

namespace mesocap::sim {

class SimulatedOperator : public drivers::RigOperator {
 public:
  explicit SimulatedOperator(std::shared_ptr<SimulatedRigState> state) : state_(std::move(state)) {}

  void PlaceCalibrationPlate(double height_mm) override {
    state_->calibration_plate_height_mm = height_mm;
    ++state_->changes;
  }
  void RemoveCalibrationPlate() override {
    state_->calibration_plate_height_mm.reset();
    ++state_->changes;
  }
  // The unit's SetMount is how the capture confirms the mount; in the
  // simulated rig the unit's state is the mount, so there is nothing to move.
  void MountLaser(int /*mount*/) override {}
  void PlaceCalibrationBoard(int holder, double /*tilt_rad*/) override {
    state_->calibration_board_holder = holder;
    ++state_->changes;
  }
  void RemoveCalibrationBoard() override {
    state_->calibration_board_holder.reset();
    ++state_->changes;
  }
  void PlaceWhiteReference(double height_mm) override {
    state_->white_reference_height_mm = height_mm;
    ++state_->changes;
  }
  void RemoveWhiteReference() override {
    state_->white_reference_height_mm.reset();
    ++state_->changes;
  }
  void PlaceMirrorSphere() override {
    state_->mirror_sphere_placed = true;
    ++state_->changes;
  }
  void RemoveMirrorSphere() override {
    state_->mirror_sphere_placed = false;
    ++state_->changes;
  }

 private:
  std::shared_ptr<SimulatedRigState> state_;
};

}  // namespace mesocap::sim
