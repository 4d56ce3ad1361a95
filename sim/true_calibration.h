// The exact calibration of a simulated rig: its nominal geometry (the rig
// description) written in the calibration format, so every processing stage
// can be run with the truth and its error separated from calibration error.
#pragma once

#include "formats/calibration.h"
#include "formats/rig_description.h"

namespace mesocap::sim {

// Cameras look at the world origin with OpenCV's camera frame (+z forward,
// +x right, +y down in the image); a laser mount's tilt axis is horizontal
// and tangent to the arc, oriented so that a positive tilt moves the stripe
// away from the laser (drivers::LaserTiltForOffset). Each camera's
// radiometry is the simulated cameras' exact gain (kSignalPerRadianceSecond).
formats::Calibration TrueCalibration(const formats::RigDescription& rig);

}  // namespace mesocap::sim
