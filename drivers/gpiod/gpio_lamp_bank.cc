#include "drivers/gpiod/gpio_lamp_bank.h"

#include "drivers/device_error.h"

namespace mesocap::drivers::gpiod {

core::CheckResult GpioLampBankOptions::Check() const {
  if (lamps.empty()) return "lamps: none (one power line a lamp)";
  if (settle.count() < 0) return "settle: " + std::to_string(settle.count()) + " ms (0 or more)";
  std::vector<std::pair<std::string, const GpioLineAddress*>> lines;
  for (std::size_t i = 0; i < lamps.size(); ++i) {
    const std::string lamp = "lamps[" + std::to_string(i) + "]";
    lines.emplace_back(lamp + ".power", &lamps[i].power);
    if (lamps[i].sense) lines.emplace_back(lamp + ".sense", &*lamps[i].sense);
  }
  return CheckLines(lines);
}

GpioLampBank::GpioLampBank(GpioLampBankOptions options, const GpioChipOpener& open, GpioTiming timing)
    : options_(std::move(options)), timing_(std::move(timing)) {
  core::ThrowIfInvalid<DeviceError>(options_.Check(), "GPIO lamps");
  GpioChips chips(open);
  for (const GpioLamp& lamp : options_.lamps) {
    Lamp& requested = lamps_.emplace_back();
    requested.power = chips.RequestOutput(lamp.power);
    if (lamp.sense) requested.sense = chips.RequestInput(*lamp.sense);
  }
}

GpioLampBank::~GpioLampBank() {
  // The lines keep their last level after release, so switch off first; a
  // chip that is gone has nothing left to switch.
  for (Lamp& lamp : lamps_) {
    try {
      lamp.power->SetActive(false);
    } catch (const DeviceError&) {
    }
  }
}

void GpioLampBank::CheckIndex(int index) const {
  if (index < 0 || index >= lamp_count()) {
    throw DeviceError("GPIO lamps: no lamp " + std::to_string(index) + " (the bank has lamps 0 to " +
                      std::to_string(lamp_count() - 1) + ")");
  }
}

void GpioLampBank::SetLamp(int index, bool on) {
  CheckIndex(index);
  Lamp& lamp = lamps_[index];
  if (!on) {
    lamp.power->SetActive(false);
    lamp.on = false;
    return;
  }
  if (lamp.on) return;
  lamp.power->SetActive(true);
  lamp.on = true;
  timing_.sleep(options_.settle);
  if (lamp.sense && !lamp.sense->IsActive()) {
    lamp.power->SetActive(false);
    lamp.on = false;
    throw LampFailureError("GPIO lamps: lamp " + std::to_string(index) +
                           " does not light (burnt out: " + lamp.sense->description() + " reads no current " +
                           std::to_string(options_.settle.count()) + " ms after switching on)");
  }
}

bool GpioLampBank::IsOn(int index) const {
  CheckIndex(index);
  return lamps_[index].on;
}

}  // namespace mesocap::drivers::gpiod
