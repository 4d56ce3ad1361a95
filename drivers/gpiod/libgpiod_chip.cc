#include "drivers/gpiod/libgpiod_chip.h"

#include <gpiod.hpp>

#include <cerrno>
#include <stdexcept>
#include <system_error>

#include "drivers/device_error.h"

namespace mesocap::drivers::gpiod {
namespace {

// The request libgpiod makes; it inverts the values of active-low lines.
::gpiod::line_request Request(const std::string& consumer, int direction, bool active_low) {
  ::gpiod::line_request request;
  request.consumer = consumer;
  request.request_type = direction;
  if (active_low) request.flags = ::gpiod::line_request::FLAG_ACTIVE_LOW;
  return request;
}

// Owns one requested line; the line holds its chip open.
class RequestedLine {
 public:
  RequestedLine(::gpiod::line line, std::string description)
      : line_(std::move(line)), description_(std::move(description)) {}
  RequestedLine(const RequestedLine&) = delete;
  RequestedLine& operator=(const RequestedLine&) = delete;
  ~RequestedLine() {
    // Release errors (the chip is gone) leave nothing to release.
    try {
      line_.release();
    } catch (const std::exception&) {
    }
  }

  const ::gpiod::line& line() const { return line_; }
  const std::string& description() const { return description_; }

 private:
  ::gpiod::line line_;
  std::string description_;
};

class LibgpiodOutputLine : public GpioOutputLine {
 public:
  LibgpiodOutputLine(::gpiod::line line, std::string description) : line_(std::move(line), std::move(description)) {}

  void SetActive(bool active) override {
    try {
      line_.line().set_value(active ? 1 : 0);
    } catch (const std::system_error& error) {
      ThrowLineFailure(line_.description(), "set the value", error.code());
    }
  }
  std::string description() const override { return line_.description(); }

 private:
  RequestedLine line_;
};

class LibgpiodInputLine : public GpioInputLine {
 public:
  LibgpiodInputLine(::gpiod::line line, std::string description) : line_(std::move(line), std::move(description)) {}

  bool IsActive() const override {
    try {
      return line_.line().get_value() != 0;
    } catch (const std::system_error& error) {
      ThrowLineFailure(line_.description(), "read the value", error.code());
    }
  }
  std::string description() const override { return line_.description(); }

 private:
  RequestedLine line_;
};

class LibgpiodChip : public GpioChip {
 public:
  LibgpiodChip(::gpiod::chip chip, std::string name) : chip_(std::move(chip)), name_(std::move(name)) {}

  std::string name() const override { return name_; }

  std::unique_ptr<GpioOutputLine> RequestOutput(const GpioLineAddress& address, const std::string& consumer,
                                                bool initially_active) override {
    const std::string description = Describe(address);
    ::gpiod::line line = Find(address, description);
    RequestLine(line, description, consumer, ::gpiod::line_request::DIRECTION_OUTPUT, address.active_low,
                initially_active);
    return std::make_unique<LibgpiodOutputLine>(std::move(line), description);
  }

  std::unique_ptr<GpioInputLine> RequestInput(const GpioLineAddress& address, const std::string& consumer) override {
    const std::string description = Describe(address);
    ::gpiod::line line = Find(address, description);
    RequestLine(line, description, consumer, ::gpiod::line_request::DIRECTION_INPUT, address.active_low, false);
    return std::make_unique<LibgpiodInputLine>(std::move(line), description);
  }

 private:
  // The address with this chip's name, whatever name it was opened by.
  std::string Describe(GpioLineAddress address) const {
    address.chip = name_;
    return address.Describe();
  }

  ::gpiod::line Find(const GpioLineAddress& address, const std::string& description) const {
    ::gpiod::line line;
    try {
      if (address.offset >= 0) {
        line = chip_.get_line(static_cast<unsigned>(address.offset));
      } else {
        line = chip_.find_line(address.name);
      }
    } catch (const std::out_of_range&) {
      throw DeviceError(description + ": no such line (the chip has " + std::to_string(chip_.num_lines()) + " lines)");
    } catch (const std::system_error& error) {
      ThrowLineFailure(description, "look up the line", error.code());
    }
    if (!line) throw DeviceError(description + ": no line of that name on the chip");
    return line;
  }

  static void RequestLine(const ::gpiod::line& line, const std::string& description, const std::string& consumer,
                          int direction, bool active_low, bool initially_active) {
    try {
      line.request(Request(consumer, direction, active_low), initially_active ? 1 : 0);
    } catch (const std::system_error& error) {
      if (error.code().value() != EBUSY) ThrowLineFailure(description, "request the line", error.code());
      // The line's information as the kernel has it now names the holder.
      std::string holder;
      try {
        line.update();
        holder = line.consumer();
      } catch (const std::exception&) {
      }
      ThrowLineInUse(description, holder);
    }
  }

  ::gpiod::chip chip_;
  std::string name_;
};

}  // namespace

std::vector<std::string> ListLibgpiodChips() {
  std::vector<std::string> chips;
  try {
    for (const ::gpiod::chip& chip : ::gpiod::make_chip_iter()) {
      chips.push_back(chip.name() + " [" + chip.label() + "]");
    }
  } catch (const std::exception& error) {
    // A chip that cannot be opened (permissions) ends the list; say so.
    chips.push_back(std::string("(more not readable: ") + error.what() + ")");
  }
  return chips;
}

std::unique_ptr<GpioChip> OpenLibgpiodChip(const std::string& name) {
  try {
    ::gpiod::chip chip(name, ::gpiod::chip::OPEN_LOOKUP);
    std::string chip_name = chip.name();
    return std::make_unique<LibgpiodChip>(std::move(chip), std::move(chip_name));
  } catch (const std::system_error& error) {
    ThrowChipCannotOpen(name, error.code().message(), ListLibgpiodChips());
  }
}

GpioChipOpener LibgpiodChipOpener() { return OpenLibgpiodChip; }

}  // namespace mesocap::drivers::gpiod
