#include "sim/true_calibration.h"

#include "calibration/nominal_geometry.h"
#include "sim/camera_renderer.h"

namespace mesocap::sim {

formats::Calibration TrueCalibration(const formats::RigDescription& rig) {
  formats::Calibration c = calibration::NominalCalibration(rig);
  // Every simulated camera renders with the same exact gain.
  for (formats::CameraCalibration& camera : c.cameras) {
    camera.radiometry =
        formats::CameraRadiometry{.signal_per_radiance_second = kSignalPerRadianceSecond, .uncertainty = {}};
  }
  return c;
}

}  // namespace mesocap::sim
