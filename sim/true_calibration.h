// The exact calibration of a simulated rig: its nominal geometry (the rig
// description) written in the calibration format, so every processing stage
// can be run with the truth and its error separated from calibration error.
#pragma once

#include "formats/calibration.h"
#include "formats/rig_description.h"

namespace mesocap::sim {

// calibration::NominalCalibration (calibration/nominal_geometry.h), and each
// camera's radiometry: the simulated cameras' exact gain
// (kSignalPerRadianceSecond).
formats::Calibration TrueCalibration(const formats::RigDescription& rig);

}  // namespace mesocap::sim
