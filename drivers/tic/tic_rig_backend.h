// The "tic" rig backend: the turntable and the light arc on Pololu Tic
// stepper controllers over USB, as the rig description names them, and the
// stage options a description gives (also for a laser tilt on a Tic).
#pragma once

#include <functional>
#include <memory>
#include <string>

#include "drivers/rig.h"
#include "drivers/tic/tic_rotary_stage.h"

namespace mesocap::drivers::tic {

// `id` names the stage in messages; speed is the stage's.
TicStageOptions StageOptions(const std::string& id, const formats::TicDescription& tic, double speed_rad_per_s);

// A stage on the real USB Tic the description names.
std::unique_ptr<RotaryStage> OpenTicStage(const std::string& id, const formats::TicDescription& tic,
                                          double speed_rad_per_s);

class TicRigBackend : public RigBackend {
 public:
  // Opens Tics by serial number: over USB (libusb) with the steady clock by
  // default; emulated Tics with their own clocks in tests.
  using ClockMaker = std::function<std::unique_ptr<StageClock>(const std::string& serial_number)>;
  TicRigBackend() = default;
  TicRigBackend(TicOpener open, ClockMaker make_clock);
  std::string name() const override { return "tic"; }
  std::unique_ptr<RotaryStage> MakeTurntable(const formats::RigDescription& rig) override;
  std::unique_ptr<RotaryStage> MakeLightArc(const formats::RigDescription& rig) override;

 private:
  std::unique_ptr<RotaryStage> Open(const std::string& id, const formats::StageDescription& stage) const;

  TicOpener open_;
  ClockMaker make_clock_;
};

}  // namespace mesocap::drivers::tic
