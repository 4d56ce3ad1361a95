#include "drivers/gpiod/emulated_gpio_chip.h"

#include <cerrno>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "drivers/device_error.h"

namespace mesocap::drivers::gpiod {

struct EmulatedGpioChipState {
  struct Line {
    std::string name;
    bool high = false;
    bool requested = false;
    std::string consumer;
  };

  std::string name;
  std::vector<Line> lines;
  EmulatedGpioChip::Clock now;
  std::vector<EmulatedGpioWrite> writes;
  std::function<void(const EmulatedGpioWrite&)> listener;
  bool vanished = false;

  std::string Describe(GpioLineAddress address) const {
    address.chip = name;
    return address.Describe();
  }
  // What the kernel answers for a chip that was unplugged.
  void ThrowIfVanished(const std::string& line, const char* doing) const {
    if (vanished) ThrowLineFailure(line, doing, std::error_code(ENODEV, std::generic_category()));
  }
  void Write(int offset, bool high) {
    lines[offset].high = high;
    writes.push_back({now(), offset, high});
    // Called on a copy: the listener may replace itself.
    if (auto call = listener) call(writes.back());
  }
};

namespace {

// One requested line; released when destroyed, as the kernel releases a
// line whose request is closed.
class EmulatedLine {
 public:
  EmulatedLine(std::shared_ptr<EmulatedGpioChipState> chip, int offset, bool active_low, std::string description)
      : chip_(std::move(chip)), offset_(offset), active_low_(active_low), description_(std::move(description)) {}
  EmulatedLine(const EmulatedLine&) = delete;
  EmulatedLine& operator=(const EmulatedLine&) = delete;
  ~EmulatedLine() {
    chip_->lines[offset_].requested = false;
    chip_->lines[offset_].consumer.clear();
  }

  const std::string& description() const { return description_; }
  void SetActive(bool active) {
    chip_->ThrowIfVanished(description_, "set the value");
    chip_->Write(offset_, active != active_low_);
  }
  bool IsActive() const {
    chip_->ThrowIfVanished(description_, "read the value");
    return chip_->lines[offset_].high != active_low_;
  }

 private:
  std::shared_ptr<EmulatedGpioChipState> chip_;
  int offset_;
  bool active_low_;
  std::string description_;
};

class EmulatedOutputLine : public GpioOutputLine {
 public:
  EmulatedOutputLine(std::shared_ptr<EmulatedGpioChipState> chip, int offset, bool active_low, std::string description)
      : line_(std::move(chip), offset, active_low, std::move(description)) {}
  void SetActive(bool active) override { line_.SetActive(active); }
  std::string description() const override { return line_.description(); }

 private:
  EmulatedLine line_;
};

class EmulatedInputLine : public GpioInputLine {
 public:
  EmulatedInputLine(std::shared_ptr<EmulatedGpioChipState> chip, int offset, bool active_low, std::string description)
      : line_(std::move(chip), offset, active_low, std::move(description)) {}
  bool IsActive() const override { return line_.IsActive(); }
  std::string description() const override { return line_.description(); }

 private:
  EmulatedLine line_;
};

}  // namespace

EmulatedGpioChip::EmulatedGpioChip(std::string name, std::vector<std::string> line_names, Clock now)
    : state_(std::make_shared<EmulatedGpioChipState>()) {
  state_->name = std::move(name);
  for (std::string& line_name : line_names) state_->lines.emplace_back().name = std::move(line_name);
  state_->now = now ? std::move(now) : GpioTiming::Real().now;
}

std::string EmulatedGpioChip::name() const { return state_->name; }

int EmulatedGpioChip::Request(const GpioLineAddress& line, const std::string& consumer) {
  const std::string description = state_->Describe(line);
  state_->ThrowIfVanished(description, "request the line");
  int offset = line.offset;
  if (offset < 0) {
    for (int i = 0; i < line_count() && offset < 0; ++i) {
      if (!line.name.empty() && state_->lines[i].name == line.name) offset = i;
    }
    if (offset < 0) throw DeviceError(description + ": no line of that name on the chip");
  } else if (offset >= line_count()) {
    throw DeviceError(description + ": no such line (the chip has " + std::to_string(line_count()) + " lines)");
  }
  EmulatedGpioChipState::Line& requested = state_->lines[offset];
  if (requested.requested) ThrowLineInUse(description, requested.consumer);
  requested.requested = true;
  requested.consumer = consumer;
  return offset;
}

std::unique_ptr<GpioOutputLine> EmulatedGpioChip::RequestOutput(const GpioLineAddress& line,
                                                                const std::string& consumer, bool initially_active) {
  auto output =
      std::make_unique<EmulatedOutputLine>(state_, Request(line, consumer), line.active_low, state_->Describe(line));
  // The kernel drives an output line from its request on.
  output->SetActive(initially_active);
  return output;
}

std::unique_ptr<GpioInputLine> EmulatedGpioChip::RequestInput(const GpioLineAddress& line,
                                                              const std::string& consumer) {
  return std::make_unique<EmulatedInputLine>(state_, Request(line, consumer), line.active_low, state_->Describe(line));
}

GpioChipOpener EmulatedGpioChip::Opener() const {
  return [chip = *this](const std::string& name) -> std::unique_ptr<GpioChip> {
    const bool present = !chip.state_->vanished;
    if (!present || (name != chip.name() && name != "/dev/" + chip.name())) {
      std::vector<std::string> here;
      if (present) here.push_back(chip.name() + " [emulated]");
      ThrowChipCannotOpen(name, std::generic_category().message(ENOENT), here);
    }
    return std::make_unique<EmulatedGpioChip>(chip);
  };
}

int EmulatedGpioChip::line_count() const { return static_cast<int>(state_->lines.size()); }

int EmulatedGpioChip::OffsetOf(const std::string& line_name) const {
  for (int i = 0; i < line_count(); ++i) {
    if (state_->lines[i].name == line_name) return i;
  }
  throw std::out_of_range("emulated " + state_->name + ": no line named " + line_name);
}

bool EmulatedGpioChip::IsHigh(int offset) const { return state_->lines.at(offset).high; }

void EmulatedGpioChip::Drive(int offset, bool high) { state_->lines.at(offset).high = high; }

bool EmulatedGpioChip::IsRequested(int offset) const { return state_->lines.at(offset).requested; }

std::string EmulatedGpioChip::ConsumerOf(int offset) const { return state_->lines.at(offset).consumer; }

void EmulatedGpioChip::HoldFor(int offset, const std::string& consumer) {
  EmulatedGpioChipState::Line& line = state_->lines.at(offset);
  line.requested = true;
  line.consumer = consumer;
}

const std::vector<EmulatedGpioWrite>& EmulatedGpioChip::writes() const { return state_->writes; }

void EmulatedGpioChip::ClearWrites() { state_->writes.clear(); }

void EmulatedGpioChip::OnWrite(std::function<void(const EmulatedGpioWrite&)> listener) {
  state_->listener = std::move(listener);
}

void EmulatedGpioChip::Vanish() { state_->vanished = true; }

}  // namespace mesocap::drivers::gpiod
