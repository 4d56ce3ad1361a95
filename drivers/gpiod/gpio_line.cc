#include "drivers/gpiod/gpio_line.h"

#include <cerrno>
#include <thread>

#include "core/error.h"
#include "drivers/device_error.h"

namespace mesocap::drivers::gpiod {

core::CheckResult GpioLineAddress::Check() const {
  if (chip.empty()) return "chip: empty (a chip's name \"gpiochip0\", path \"/dev/gpiochip0\" or label)";
  if (offset < -1) return "offset: " + std::to_string(offset) + " (a line's offset is 0 or more; -1 finds it by name)";
  if (offset == -1 && name.empty()) return "line: neither an offset nor a name";
  if (offset >= 0 && !name.empty()) {
    return "line: both offset " + std::to_string(offset) + " and name " + core::Quoted(name) + " (give one)";
  }
  return "";
}

std::string GpioLineAddress::Describe() const {
  std::string line = offset >= 0 ? std::to_string(offset) : core::Quoted(name);
  return "GPIO " + core::Cut(chip) + " line " + line;
}

GpioChip& GpioChips::Open(const std::string& chip) {
  std::unique_ptr<GpioChip>& opened = chips_[chip];
  if (!opened) opened = open_(chip);
  return *opened;
}

std::unique_ptr<GpioOutputLine> GpioChips::RequestOutput(const GpioLineAddress& line) {
  return Open(line.chip).RequestOutput(line, kGpioConsumer, false);
}

std::unique_ptr<GpioInputLine> GpioChips::RequestInput(const GpioLineAddress& line) {
  return Open(line.chip).RequestInput(line, kGpioConsumer);
}

void ThrowChipCannotOpen(const std::string& chip, const std::string& why, const std::vector<std::string>& chips_here) {
  std::string here;
  for (const std::string& name : chips_here) here += (here.empty() ? "" : ", ") + name;
  throw DeviceError("GPIO chip " + core::Quoted(chip) + ": cannot open: " + why +
                    "; chips here: " + (here.empty() ? "none" : here));
}

void ThrowLineInUse(const std::string& line, const std::string& consumer) {
  const std::string holder = consumer.empty() ? "another process" : core::Quoted(consumer);
  throw DeviceError(line + ": in use by " + holder + " (" + std::generic_category().message(EBUSY) + ")");
}

void ThrowLineFailure(const std::string& line, const std::string& doing, std::error_code error) {
  const std::string message = line + ": cannot " + doing + ": " + error.message();
  if (error.value() == ENODEV) throw DisconnectedError(message + " (the chip is gone)");
  throw DeviceError(message);
}

namespace {

// Two addresses name the same line when chip and offset (or name) agree; a
// line given by offset and the same line by name cannot be told apart here.
bool SameLine(const GpioLineAddress& a, const GpioLineAddress& b) {
  return a.chip == b.chip && a.offset == b.offset && a.name == b.name;
}

}  // namespace

std::string CheckLines(const std::vector<std::pair<std::string, const GpioLineAddress*>>& lines) {
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto& [field, address] = lines[i];
    if (std::string problem = address->Check(); !problem.empty()) return field + "." + problem;
    for (std::size_t j = 0; j < i; ++j) {
      if (SameLine(*lines[j].second, *address)) {
        return field + ": " + address->Describe() + " is already " + lines[j].first;
      }
    }
  }
  return "";
}

GpioTiming GpioTiming::Real() {
  return {
      [](std::chrono::nanoseconds duration) { std::this_thread::sleep_for(duration); },
      [] {
        const auto since_epoch = std::chrono::steady_clock::now().time_since_epoch();
        return std::chrono::duration_cast<std::chrono::nanoseconds>(since_epoch);
      },
  };
}

}  // namespace mesocap::drivers::gpiod
