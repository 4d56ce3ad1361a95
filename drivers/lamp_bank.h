// The lamps on the light arc (MDF paper Sec. 3.1: eight halogen lamps,
// switched one at a time for BTF capture).
#pragma once

namespace mesocap::drivers {

class LampBank {
 public:
  virtual ~LampBank() = default;

  virtual int lamp_count() const = 0;
  // Throws DeviceError for an index out of range, LampFailureError when the
  // lamp does not light.
  virtual void SetLamp(int index, bool on) = 0;
  virtual bool IsOn(int index) const = 0;
  void AllOff() {
    for (int i = 0; i < lamp_count(); ++i) SetLamp(i, false);
  }
};

}  // namespace mesocap::drivers
