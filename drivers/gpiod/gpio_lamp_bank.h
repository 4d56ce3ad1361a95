// The lamps of the light arc on GPIO lines: each lamp switched by an output
// line (through a relay or MOSFET board), optionally watched by an input line
// from a current sensor.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "drivers/gpiod/gpio_line.h"
#include "drivers/lamp_bank.h"

namespace mesocap::drivers::gpiod {

struct GpioLamp {
  GpioLineAddress power;  // active: the lamp is on
  // Active while the lamp draws current; inactive once it has settled means
  // the lamp is burnt out.
  std::optional<GpioLineAddress> sense;
};

struct GpioLampBankOptions {
  std::vector<GpioLamp> lamps;
  // A halogen lamp's warm-up: SetLamp(on) returns once its light is steady.
  std::chrono::milliseconds settle{200};

  core::CheckResult Check() const;
};

// Switches one lamp at a time or several; every lamp is off once it is
// built and when it is destroyed. Lamp names in messages are their indices.
class GpioLampBank : public LampBank {
 public:
  // Throws DeviceError for options that fail Check() or lines that cannot be
  // requested.
  GpioLampBank(GpioLampBankOptions options, const GpioChipOpener& open, GpioTiming timing = GpioTiming::Real());
  ~GpioLampBank() override;

  int lamp_count() const override { return static_cast<int>(lamps_.size()); }
  // Switching on waits the settle time, then reads the sense line; a lamp
  // that draws no current is switched off again (LampFailureError).
  void SetLamp(int index, bool on) override;
  bool IsOn(int index) const override;

 private:
  struct Lamp {
    std::unique_ptr<GpioOutputLine> power;
    std::unique_ptr<GpioInputLine> sense;
    bool on = false;
  };

  void CheckIndex(int index) const;

  GpioLampBankOptions options_;
  GpioTiming timing_;
  std::vector<Lamp> lamps_;
};

}  // namespace mesocap::drivers::gpiod
