// The laser scan unit (MDF paper Sec. 3.1-3.2, Fig. 3b): a line laser whose
// emitter is tilted by a geared motor so that the stripe sweeps across the
// turntable. It sits on the light arc at one of several mounts; in the
// paper it is remounted by hand between scans.
#pragma once

#include <chrono>

namespace mesocap::drivers {

class LaserUnit {
 public:
  virtual ~LaserUnit() = default;

  virtual void SetEnabled(bool on) = 0;
  virtual bool IsEnabled() const = 0;

  // Tilt of the emitter about its tilt axis (radians; the calibration gives
  // the plane at tilt 0). SetTilt moves and blocks until there, or throws
  // TimeoutError / StallError.
  virtual void SetTilt(double tilt_rad, std::chrono::milliseconds timeout) = 0;
  virtual double Tilt() const = 0;

  // Which mount on the light arc the unit sits on. A unit that is moved by
  // hand reports the mount the operator confirmed with SetMount.
  virtual int mount_count() const = 0;
  virtual int mount() const = 0;
  virtual void SetMount(int mount) = 0;
};

}  // namespace mesocap::drivers
