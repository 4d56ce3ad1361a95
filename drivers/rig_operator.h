// The person at the rig, for the steps no motor does: laying the flat
// calibration plates of the laser-plane calibration on the turntable (MDF
// paper Sec. 3.2), moving the laser unit between its mounts on the light
// arc (Fig. 4: "we simply remount the laser unit ... manually"), setting
// the calibration board's holder to each of its tilts, and laying the white
// reference of the radiometric calibration and the mirror sphere of the
// lamps' calibration. A capture
// asks, the operator does it and confirms by returning; a real backend
// prompts on the console, the simulated one changes the simulated rig.
#pragma once

namespace mesocap::drivers {

class RigOperator {
 public:
  virtual ~RigOperator() = default;

  // Lay the plate flat over the turntable with its top at height_mm above
  // the reference plane (the sample stays under it).
  virtual void PlaceCalibrationPlate(double height_mm) = 0;
  virtual void RemoveCalibrationPlate() = 0;
  // Move the laser unit to mount `mount` of the light arc.
  virtual void MountLaser(int mount) = 0;
  // Set the rig's calibration board on the turntable on its holder at tilt
  // `holder` (of the rig description's calibration_board.holder_tilts),
  // tilted by `tilt_rad`; and take it off again.
  virtual void PlaceCalibrationBoard(int holder, double tilt_rad) = 0;
  virtual void RemoveCalibrationBoard() = 0;
  // Lay the rig's white reference flat over the turntable, its top at
  // height_mm above the reference plane; and take it off again.
  virtual void PlaceWhiteReference(double height_mm) = 0;
  virtual void RemoveWhiteReference() = 0;
  // Set the rig's mirror sphere in its cup at the sample centre; and take it
  // off again.
  virtual void PlaceMirrorSphere() = 0;
  virtual void RemoveMirrorSphere() = 0;
};

}  // namespace mesocap::drivers
