#include "drivers/tic/tic_rig_backend.h"

#include "core/error.h"
#include "drivers/tic/libusb_tic_transport.h"
#include "drivers/tic/stage_clock.h"

namespace mesocap::drivers::tic {
namespace {

TicProduct ProductNamed(const std::string& name) {
  for (const TicProduct p : kTicProducts) {
    // "Tic T825 Stepper Motor Controller" holds " T825 ".
    if (ProductName(p).find(" " + name + " ") != std::string::npos) return p;
  }
  throw core::Error("unknown Tic product " + core::Quoted(name));
}

}  // namespace

TicStageOptions StageOptions(const std::string& id, const formats::TicDescription& tic, double speed_rad_per_s) {
  TicStageOptions o;
  o.id = id;
  o.serial_number = tic.serial;
  o.product = ProductNamed(tic.product);
  o.full_steps_per_revolution = tic.full_steps_per_revolution;
  o.microsteps = tic.microsteps;
  o.gear_ratio = tic.gear_ratio;
  o.max_speed_rad_per_s = speed_rad_per_s;
  o.homing_direction = tic.home_forward ? HomingDirection::kForward : HomingDirection::kReverse;
  return o;
}

std::unique_ptr<RotaryStage> OpenTicStage(const std::string& id, const formats::TicDescription& tic,
                                          double speed_rad_per_s) {
  return std::make_unique<TicRotaryStage>(StageOptions(id, tic, speed_rad_per_s), LibusbTicOpener(),
                                          std::make_unique<SteadyStageClock>());
}

TicRigBackend::TicRigBackend(TicOpener open, ClockMaker make_clock)
    : open_(std::move(open)), make_clock_(std::move(make_clock)) {}

std::unique_ptr<RotaryStage> TicRigBackend::Open(const std::string& id, const formats::StageDescription& stage) const {
  if (!open_) return OpenTicStage(id, stage.tic, stage.speed_rad_per_s);
  return std::make_unique<TicRotaryStage>(StageOptions(id, stage.tic, stage.speed_rad_per_s), open_,
                                          make_clock_(stage.tic.serial));
}

std::unique_ptr<RotaryStage> TicRigBackend::MakeTurntable(const formats::RigDescription& rig) {
  return Open("turntable", rig.turntable);
}

std::unique_ptr<RotaryStage> TicRigBackend::MakeLightArc(const formats::RigDescription& rig) {
  return Open("light arc", rig.light_arc);
}

}  // namespace mesocap::drivers::tic
