// The seam between the GPIO devices and the lines they drive: a chip hands
// out requested lines, each line is released when its object is destroyed.
// OpenLibgpiodChip drives the kernel's lines through libgpiod; EmulatedGpioChip
// stands in for it in tests.
#pragma once

#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "core/error.h"

namespace mesocap::drivers::gpiod {

// The consumer every line is requested as, so `gpioinfo` shows who holds it.
inline constexpr const char* kGpioConsumer = "mesocap";

// One line: on a chip (its name "gpiochip0", its path "/dev/gpiochip0" or
// its label), by offset or, with offset -1, by the line's name.
struct GpioLineAddress {
  std::string chip;
  int offset = -1;
  std::string name;
  // The line is active at the low level (an inverting driver, a switch to
  // ground): values read and written are the active state, not the level.
  bool active_low = false;

  core::CheckResult Check() const;
  // How messages name the line: `GPIO gpiochip0 line 17` or
  // `GPIO gpiochip0 line "LAMP3"`.
  std::string Describe() const;
};

// A requested output line.
class GpioOutputLine {
 public:
  virtual ~GpioOutputLine() = default;
  // Throws DisconnectedError when the chip is gone.
  virtual void SetActive(bool active) = 0;
  virtual std::string description() const = 0;
};

// A requested input line.
class GpioInputLine {
 public:
  virtual ~GpioInputLine() = default;
  // Throws DisconnectedError when the chip is gone.
  virtual bool IsActive() const = 0;
  virtual std::string description() const = 0;
};

// An open GPIO chip. Requested lines keep what they need of the chip, so
// they may outlive this object.
class GpioChip {
 public:
  virtual ~GpioChip() = default;
  virtual std::string name() const = 0;
  // Throw DeviceError naming the line when it does not exist, or when it is
  // in use (naming its consumer); DisconnectedError when the chip is gone.
  // `line.chip` is not looked at: the caller chose this chip by it.
  virtual std::unique_ptr<GpioOutputLine> RequestOutput(const GpioLineAddress& line, const std::string& consumer,
                                                        bool initially_active) = 0;
  virtual std::unique_ptr<GpioInputLine> RequestInput(const GpioLineAddress& line, const std::string& consumer) = 0;
};

// Opens the chip an address names; throws DeviceError naming the chip.
using GpioChipOpener = std::function<std::unique_ptr<GpioChip>(const std::string& chip)>;

// The chips one device's lines are on, each opened once, as it requests
// its lines (consumer kGpioConsumer).
class GpioChips {
 public:
  explicit GpioChips(GpioChipOpener open) : open_(std::move(open)) {}

  // Outputs are requested inactive, so what they switch starts off.
  std::unique_ptr<GpioOutputLine> RequestOutput(const GpioLineAddress& line);
  std::unique_ptr<GpioInputLine> RequestInput(const GpioLineAddress& line);

 private:
  GpioChip& Open(const std::string& chip);

  GpioChipOpener open_;
  std::map<std::string, std::unique_ptr<GpioChip>> chips_;  // by the name asked for
};

// The failures both chips report, worded alike.
// A chip that cannot be opened: `GPIO chip "gpiochip0": cannot open: No such
// file or directory; chips here: none` (DeviceError).
[[noreturn]] void ThrowChipCannotOpen(const std::string& chip, const std::string& why,
                                      const std::vector<std::string>& chips_here);
// A line another consumer holds: `GPIO gpiochip0 line 3: in use by "gpio-fan"
// (Device or resource busy)` (DeviceError).
[[noreturn]] void ThrowLineInUse(const std::string& line, const std::string& consumer);
// An operation on a line failed; ENODEV (the chip was unplugged or unbound)
// is a DisconnectedError, anything else a DeviceError.
[[noreturn]] void ThrowLineFailure(const std::string& line, const std::string& doing, std::error_code error);

// Options' Check() for a set of lines: each valid, no line used twice.
// `lines` pairs each line's field name with its address.
std::string CheckLines(const std::vector<std::pair<std::string, const GpioLineAddress*>>& lines);

// How the devices wait and tell time: real by default, injected by tests so
// that a settle time or a step pulse is recorded, not slept.
struct GpioTiming {
  std::function<void(std::chrono::nanoseconds)> sleep;
  std::function<std::chrono::nanoseconds()> now;

  // std::this_thread::sleep_for and std::chrono::steady_clock.
  static GpioTiming Real();
};

}  // namespace mesocap::drivers::gpiod
