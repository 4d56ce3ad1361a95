#include "acquisition/prompted_operator.h"

#include <cstdio>

#include "core/angles.h"

namespace mesocap::acquisition {
namespace {

std::string Millimetres(double mm) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g mm", mm);
  return text;
}

}  // namespace

PromptedOperator::PromptedOperator(drivers::RigOperator& hands, OperatorPrompt prompt)
    : hands_(hands), prompt_(std::move(prompt)) {}

void PromptedOperator::PlaceCalibrationPlate(double height_mm) {
  prompt_("Lay the flat calibration plate over the turntable, its top " + Millimetres(height_mm) +
          " above the reference plane");
  hands_.PlaceCalibrationPlate(height_mm);
}

void PromptedOperator::RemoveCalibrationPlate() {
  prompt_("Take the calibration plate off the turntable");
  hands_.RemoveCalibrationPlate();
}

void PromptedOperator::MountLaser(int mount) {
  prompt_("Move the laser unit to mount " + std::to_string(mount) + " of the light arc");
  hands_.MountLaser(mount);
}

void PromptedOperator::PlaceCalibrationBoard(int holder, double tilt_rad) {
  char tilt[32];
  std::snprintf(tilt, sizeof tilt, "%.3g", core::DegreesFromRadians(tilt_rad));
  prompt_("Set the calibration board on the turntable on holder " + std::to_string(holder) + " (tilt " + tilt +
          " deg)");
  hands_.PlaceCalibrationBoard(holder, tilt_rad);
}

void PromptedOperator::RemoveCalibrationBoard() {
  prompt_("Take the calibration board off the turntable");
  hands_.RemoveCalibrationBoard();
}

void PromptedOperator::PlaceWhiteReference(double height_mm) {
  prompt_("Lay the white reference over the turntable, its top " + Millimetres(height_mm) +
          " above the reference plane");
  hands_.PlaceWhiteReference(height_mm);
}

void PromptedOperator::RemoveWhiteReference() {
  prompt_("Take the white reference off the turntable");
  hands_.RemoveWhiteReference();
}

void PromptedOperator::PlaceMirrorSphere() {
  prompt_("Set the mirror sphere in its cup at the centre of the turntable");
  hands_.PlaceMirrorSphere();
}

void PromptedOperator::RemoveMirrorSphere() {
  prompt_("Take the mirror sphere off the turntable");
  hands_.RemoveMirrorSphere();
}

}  // namespace mesocap::acquisition
