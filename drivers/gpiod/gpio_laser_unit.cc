#include "drivers/gpiod/gpio_laser_unit.h"
#include "core/angles.h"

#include <cmath>
#include <numbers>

#include "drivers/device_error.h"

namespace mesocap::drivers::gpiod {
namespace {

std::string Mounts(int count) { return "(the arc has mounts 0 to " + std::to_string(count - 1) + ")"; }

}  // namespace

core::CheckResult GpioLaserOptions::Check() const {
  if (std::string problem = CheckLines({{"enable", &enable}}); !problem.empty()) return problem;
  if (!(std::isfinite(max_tilt_rad) && max_tilt_rad > 0.0 && max_tilt_rad < std::numbers::pi)) {
    return "max_tilt_rad: " + std::to_string(max_tilt_rad) + " (above 0, below pi)";
  }
  if (mount_count < 1) return "mount_count: " + std::to_string(mount_count) + " (1 or more)";
  if (mount < 0 || mount >= mount_count) return "mount: " + std::to_string(mount) + " " + Mounts(mount_count);
  return "";
}

GpioLaserUnit::GpioLaserUnit(GpioLaserOptions options, const GpioChipOpener& open, std::unique_ptr<RotaryStage> tilt)
    : options_(std::move(options)), tilt_(std::move(tilt)), mount_(options_.mount) {
  core::ThrowIfInvalid<DeviceError>(options_.Check(), "GPIO laser unit");
  if (!tilt_) throw DeviceError("GPIO laser unit: no tilt stage");
  // Requested inactive: the laser is off from here on.
  enable_ = GpioChips(open).RequestOutput(options_.enable);
}

GpioLaserUnit::~GpioLaserUnit() {
  // The line keeps its level after release; a chip that is gone has no laser
  // left to switch.
  try {
    enable_->SetActive(false);
  } catch (const DeviceError&) {
  }
}

void GpioLaserUnit::SetEnabled(bool on) {
  enable_->SetActive(on);
  enabled_ = on;
}

void GpioLaserUnit::SetTilt(double tilt_rad, std::chrono::milliseconds timeout) {
  if (!(std::abs(tilt_rad) <= options_.max_tilt_rad)) {
    throw DeviceError("GPIO laser unit: tilt " + std::to_string(tilt_rad) + " rad is outside [-" +
                      std::to_string(options_.max_tilt_rad) + ", " + std::to_string(options_.max_tilt_rad) + "] rad");
  }
  if (!tilt_->IsHomed()) tilt_->Home();
  tilt_->MoveTo(tilt_rad < 0.0 ? tilt_rad + core::kTwoPi : tilt_rad);
  tilt_->WaitUntilStopped(timeout);
}

double GpioLaserUnit::Tilt() const { return std::remainder(tilt_->Position(), core::kTwoPi); }

void GpioLaserUnit::SetMount(int mount) {
  if (mount < 0 || mount >= options_.mount_count) {
    throw DeviceError("GPIO laser unit: no mount " + std::to_string(mount) + " " + Mounts(options_.mount_count));
  }
  mount_ = mount;
}

}  // namespace mesocap::drivers::gpiod
