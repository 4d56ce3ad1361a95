// A GPIO chip in memory that behaves as the kernel's does to its users, for
// tests of the GPIO devices: lines by offset and by name, each requested by
// one consumer at a time (a second request is "Device or resource busy"),
// active-low applied, released when the line object goes. The test drives
// the inputs, sees every level written with its time, and can make the chip
// vanish as an unplugged one does.
//
// Copies share one emulated chip: hand one (or Opener()) to the device under
// test and keep one to drive and inspect. Not thread-safe.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "drivers/gpiod/gpio_line.h"

namespace mesocap::drivers::gpiod {

// What the emulated chip holds; shared by its copies and requested lines.
struct EmulatedGpioChipState;

// A level written to an output line (including its level when requested).
struct EmulatedGpioWrite {
  std::chrono::nanoseconds time{0};
  int offset = 0;
  bool high = false;  // the level on the pin, after active-low
};

class EmulatedGpioChip : public GpioChip {
 public:
  using Clock = std::function<std::chrono::nanoseconds()>;

  // `line_names` gives the lines, one a line in offset order ("" for an
  // unnamed line). `now` stamps the writes; the steady clock when empty.
  EmulatedGpioChip(std::string name, std::vector<std::string> line_names, Clock now = {});

  std::string name() const override;
  std::unique_ptr<GpioOutputLine> RequestOutput(const GpioLineAddress& line, const std::string& consumer,
                                                bool initially_active) override;
  std::unique_ptr<GpioInputLine> RequestInput(const GpioLineAddress& line, const std::string& consumer) override;

  // Opens this chip by its name or "/dev/" + its name, as LibgpiodChipOpener
  // does a kernel chip; any other chip (or this one once vanished) cannot be
  // opened.
  GpioChipOpener Opener() const;

  // The test's side.
  int line_count() const;
  // The offset of the line of that name; std::out_of_range when none.
  int OffsetOf(const std::string& line_name) const;
  // The level on the pin: what was last written to an output, or driven
  // onto an input.
  bool IsHigh(int offset) const;
  // Drives the level of a pin that is an input (a switch, a sensor).
  void Drive(int offset, bool high);
  bool IsRequested(int offset) const;
  std::string ConsumerOf(int offset) const;
  // Another process requests the line, as `gpioset` would.
  void HoldFor(int offset, const std::string& consumer);
  const std::vector<EmulatedGpioWrite>& writes() const;
  void ClearWrites();
  // Called after every write, e.g. to turn an emulated motor and its limit
  // switch as step pulses arrive; it may Drive() inputs.
  void OnWrite(std::function<void(const EmulatedGpioWrite&)> listener);
  // The chip is unplugged: every operation on it or its lines throws
  // DisconnectedError ("No such device"), and it cannot be opened again.
  void Vanish();

 private:
  // Looks the line up and marks it requested; returns its offset.
  int Request(const GpioLineAddress& line, const std::string& consumer);

  std::shared_ptr<EmulatedGpioChipState> state_;
};

}  // namespace mesocap::drivers::gpiod
