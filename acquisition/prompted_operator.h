// The operator of a capture that a person runs from afar: before each step
// no motor does (lay a plate, remount the laser, set the board's tilt; MDF
// paper Sec. 3.2 and Fig. 4), it asks through `prompt` and waits for the
// answer; then the hands behind it act (the simulated rig changes its
// scene; on a real rig the person already did it, and the hands do nothing).
#pragma once

#include <functional>
#include <string>

#include "core/error.h"
#include "drivers/rig_operator.h"

namespace mesocap::acquisition {

// Shows `instruction` to the person at the rig and returns once they say it
// is done. Throws CaptureInterrupted to end the run instead (the daemon
// stops, or the job is paused or cancelled while it waits).
using OperatorPrompt = std::function<void(const std::string& instruction)>;

// A run ended on purpose inside a step: nothing is wrong with the rig, and
// the step is done again from its start when the session resumes.
class CaptureInterrupted : public core::Error {
 public:
  using core::Error::Error;
};

class PromptedOperator : public drivers::RigOperator {
 public:
  PromptedOperator(drivers::RigOperator& hands, OperatorPrompt prompt);

  void PlaceCalibrationPlate(double height_mm) override;
  void RemoveCalibrationPlate() override;
  void MountLaser(int mount) override;
  void PlaceCalibrationBoard(int holder, double tilt_rad) override;
  void RemoveCalibrationBoard() override;
  void PlaceWhiteReference(double height_mm) override;
  void RemoveWhiteReference() override;
  void PlaceMirrorSphere() override;
  void RemoveMirrorSphere() override;

 private:
  drivers::RigOperator& hands_;
  OperatorPrompt prompt_;
};

}  // namespace mesocap::acquisition
