#include "drivers/tic/emulated_tic.h"

#include <algorithm>
#include <cmath>

#include "drivers/device_error.h"

namespace mesocap::drivers::tic {

// One USB connection to the emulated Tic; dead once the Tic is unplugged,
// even after it is plugged in again (as a libusb handle would be).
class EmulatedTicTransport : public TicTransport {
 public:
  explicit EmulatedTicTransport(EmulatedTic& tic) : tic_(tic), connection_(tic.connection_), info_(tic.info()) {}

  const TicDeviceInfo& info() const override { return info_; }

  std::size_t ControlTransfer(const ControlSetup& setup, std::span<std::uint8_t> data) override {
    if (!tic_.plugged_in_ || tic_.connection_ != connection_) {
      throw DisconnectedError("Tic " + info_.serial_number + ": no such device (it may have been disconnected)");
    }
    if (tic_.timeouts_to_inject_ > 0) {
      --tic_.timeouts_to_inject_;
      throw TimeoutError("Tic " + info_.serial_number + ": operation timed out");
    }
    return tic_.Answer(setup, data);
  }

 private:
  EmulatedTic& tic_;
  int connection_;
  TicDeviceInfo info_;
};

namespace {

class EmulatedTicClock : public StageClock {
 public:
  explicit EmulatedTicClock(EmulatedTic& tic) : tic_(tic) {}
  std::chrono::nanoseconds Now() override { return tic_.now(); }
  void SleepFor(std::chrono::nanoseconds duration) override { tic_.Advance(duration); }

 private:
  EmulatedTic& tic_;
};

std::chrono::nanoseconds SecondsToNanoseconds(double seconds) {
  return std::chrono::nanoseconds(static_cast<std::int64_t>(std::ceil(seconds * 1e9)));
}

constexpr std::uint16_t kStoppingErrors = 0xFFFF;  // any bit of error status stops the motor

}  // namespace

EmulatedTic::EmulatedTic(EmulatedTicOptions options) : options_(std::move(options)) {
  vin_mv_ = options_.vin_mv;
  PowerUp();
}

TicDeviceInfo EmulatedTic::info() const {
  TicDeviceInfo info;
  info.serial_number = options_.serial_number;
  info.product = options_.product;
  info.product_name = ProductName(options_.product);
  info.bus_address = "emulated bus address " + std::to_string(connection_ + 1);
  return info;
}

void EmulatedTic::PowerUp() {
  count_offset_ = -shaft_;
  target_ = 0;
  planning_ = TicPlanningMode::kOff;
  homing_ = false;
  position_uncertain_ = true;
  error_status_ = 0;
  errors_occurred_ = 0;
  max_speed_ = options_.max_speed;
  step_mode_ = 0;
  last_timeout_reset_ = now_;
  // In serial/USB control the Tic starts in safe start.
  SetError(TicErrorBit::kSafeStartViolation);
  if (vin_mv_ == 0) SetError(TicErrorBit::kLowVin);
}

std::unique_ptr<StageClock> EmulatedTic::MakeClock() { return std::make_unique<EmulatedTicClock>(*this); }

std::unique_ptr<TicTransport> EmulatedTic::Open() { return std::make_unique<EmulatedTicTransport>(*this); }

TicOpener EmulatedTic::Opener() {
  return [this](const std::string& serial_number) -> std::unique_ptr<TicTransport> {
    if (!plugged_in_ || serial_number != options_.serial_number) {
      const std::string found = plugged_in_ ? Describe(info()) : "none";
      throw DeviceError("no Tic with serial " + serial_number + " found (found: " + found + ")");
    }
    return Open();
  };
}

void EmulatedTic::SetError(TicErrorBit bit) {
  error_status_ |= static_cast<std::uint16_t>(ErrorMask(bit));
  errors_occurred_ |= ErrorMask(bit);
  if (bit != TicErrorBit::kSafeStartViolation) {
    // With safe start on, any error leaves a safe start violation behind that
    // only "exit safe start" clears.
    error_status_ |= static_cast<std::uint16_t>(ErrorMask(TicErrorBit::kSafeStartViolation));
    errors_occurred_ |= ErrorMask(TicErrorBit::kSafeStartViolation);
  }
  Halt();
}

void EmulatedTic::ClearError(TicErrorBit bit) { error_status_ &= static_cast<std::uint16_t>(~ErrorMask(bit)); }

void EmulatedTic::Halt() {
  planning_ = TicPlanningMode::kOff;
  homing_ = false;
  target_ = static_cast<std::int32_t>(std::lround(Count()));
}

double EmulatedTic::SpeedMicrostepsPerSecond() const {
  return (homing_ ? options_.homing_speed : max_speed_) / kSpeedUnitsPerStepPerSecond;
}

bool EmulatedTic::Moving() const {
  if (error_status_ & kStoppingErrors) return false;
  if (homing_) return true;
  // Within a millionth of a step counts as there: the shaft is a double.
  return planning_ == TicPlanningMode::kTargetPosition && std::abs(Count() - target_) > 1e-6;
}

int EmulatedTic::Direction() const {
  if (homing_) return homing_direction_ == HomingDirection::kForward ? 1 : -1;
  return target_ > Count() ? 1 : -1;
}

std::optional<double> EmulatedTic::NextSwitch() const {
  const double home = static_cast<double>(options_.home_switch_microsteps);
  const double revolution = static_cast<double>(options_.revolution_microsteps);
  const int direction = Direction();
  if (revolution <= 0) {
    if ((home - shaft_) * direction >= 0) return home;
    return std::nullopt;
  }
  // The switch position home + k * revolution at or ahead of the shaft.
  const double turns = (shaft_ - home) / revolution;
  const double k = direction > 0 ? std::ceil(turns) : std::floor(turns);
  return home + k * revolution;
}

bool EmulatedTic::CommandTimeoutArmed() const {
  return options_.command_timeout.count() > 0 && !(error_status_ & ErrorMask(TicErrorBit::kCommandTimeout));
}

void EmulatedTic::Advance(std::chrono::nanoseconds duration) {
  now_ += duration;
  Update();
}

// Runs the Tic from the last update to now_, one event at a time: the
// command timeout expiring, the target reached, the home switch hit.
void EmulatedTic::Update() {
  while (updated_to_ < now_) {
    std::chrono::nanoseconds step = now_ - updated_to_;
    enum class Event { kNone, kTimeout, kArrival, kSwitch } event = Event::kNone;
    if (CommandTimeoutArmed()) {
      const std::chrono::nanoseconds until = last_timeout_reset_ + options_.command_timeout - updated_to_;
      if (until <= step) step = std::max(until, std::chrono::nanoseconds(0)), event = Event::kTimeout;
    }
    const bool turning = Moving() && !stalled_;
    double goal = 0.0;  // shaft position of the arrival or switch
    if (turning) {
      std::optional<double> stop;
      if (homing_) {
        stop = NextSwitch();
      } else {
        stop = target_ - count_offset_;
      }
      if (stop) {
        const std::chrono::nanoseconds until =
            SecondsToNanoseconds(std::abs(*stop - shaft_) / SpeedMicrostepsPerSecond());
        if (until <= step) {
          step = until;
          goal = *stop;
          event = homing_ ? Event::kSwitch : Event::kArrival;
        }
      }
    }
    if (turning) {
      shaft_ += Direction() * SpeedMicrostepsPerSecond() * std::chrono::duration<double>(step).count();
    }
    updated_to_ += step;
    switch (event) {
      case Event::kNone:
        break;
      case Event::kTimeout:
        SetError(TicErrorBit::kCommandTimeout);
        break;
      case Event::kArrival:
        shaft_ = goal;
        break;
      case Event::kSwitch:
        // Homing ends at the switch, which becomes position 0.
        shaft_ = goal;
        count_offset_ = -shaft_;
        homing_ = false;
        position_uncertain_ = false;
        target_ = 0;
        planning_ = TicPlanningMode::kOff;
        break;
    }
  }
}

void EmulatedTic::LoseMotorPower() {
  Update();
  vin_mv_ = 0;
  SetError(TicErrorBit::kLowVin);
  position_uncertain_ = true;
}

void EmulatedTic::RestoreMotorPower() {
  Update();
  vin_mv_ = options_.vin_mv;
  ClearError(TicErrorBit::kLowVin);
}

void EmulatedTic::Unplug() {
  Update();
  plugged_in_ = false;
  ++connection_;
}

void EmulatedTic::PlugIn(bool power_cycled) {
  Update();
  plugged_in_ = true;
  if (power_cycled) PowerUp();
}

int EmulatedTic::commands_received(TicCommand command) const {
  const auto found = commands_received_.find(static_cast<std::uint8_t>(command));
  return found == commands_received_.end() ? 0 : found->second;
}

TicVariables EmulatedTic::Variables() const {
  TicVariables v;
  const bool deenergized =
      error_status_ & (ErrorMask(TicErrorBit::kIntentionallyDeenergized) | ErrorMask(TicErrorBit::kMotorDriverError) |
                       ErrorMask(TicErrorBit::kLowVin) | ErrorMask(TicErrorBit::kKillSwitch));
  v.operation_state = static_cast<std::uint8_t>(deenergized          ? TicOperationState::kDeenergized
                                                : error_status_ != 0 ? TicOperationState::kSoftError
                                                                     : TicOperationState::kNormal);
  v.energized = !deenergized;
  v.position_uncertain = position_uncertain_;
  v.homing_active = homing_;
  v.error_status = error_status_;
  v.errors_occurred = errors_occurred_;
  v.planning_mode = static_cast<std::uint8_t>(planning_);
  v.target_position = target_;
  v.max_speed = max_speed_;
  v.current_position = static_cast<std::int32_t>(std::lround(Count()));
  if (Moving()) {
    const std::uint32_t speed = homing_ ? options_.homing_speed : max_speed_;
    v.current_velocity = Direction() * static_cast<std::int32_t>(speed);
  }
  v.acting_target_position = target_;
  v.vin_voltage_mv = vin_mv_;
  v.up_time_ms = static_cast<std::uint32_t>(std::chrono::duration_cast<std::chrono::milliseconds>(now_).count());
  v.step_mode = step_mode_;
  return v;
}

void EmulatedTic::Reject(const ControlSetup& setup, const std::string& why) const {
  const char* digits = "0123456789ABCDEF";
  const std::string request = {digits[setup.request >> 4], digits[setup.request & 0xF]};
  throw DeviceError("Tic " + options_.serial_number + " request 0x" + request + ": " + why +
                    " (pipe error: the Tic stalled the control pipe)");
}

std::size_t EmulatedTic::Answer(const ControlSetup& setup, std::span<std::uint8_t> data) {
  Update();
  const std::optional<CommandArgument> argument = ArgumentOf(setup.request);
  if (!argument) Reject(setup, "unknown request");
  if (*argument == CommandArgument::kReadsData) {
    if (setup.request_type != kVendorDeviceToHost) Reject(setup, "a read sent as a write");
    const std::vector<std::uint8_t> block = EncodeVariables(Variables());
    if (setup.value != 0 || setup.length == 0 || setup.index + setup.length > block.size() ||
        data.size() < setup.length) {
      Reject(setup, "variables out of range");
    }
    std::copy_n(block.begin() + setup.index, setup.length, data.begin());
    if (static_cast<TicCommand>(setup.request) == TicCommand::kGetVariableAndClearErrorsOccurred) {
      errors_occurred_ = 0;
    }
    return setup.length;
  }
  if (setup.request_type != kVendorHostToDevice) Reject(setup, "a command sent as a read");
  if (setup.length != 0) Reject(setup, "a command with a data stage");
  if (*argument == CommandArgument::kNone && (setup.value != 0 || setup.index != 0)) {
    Reject(setup, "arguments to a command that takes none");
  }
  if (*argument == CommandArgument::kSevenBit && (setup.value > 0x7F || setup.index != 0)) {
    Reject(setup, "a 7-bit argument out of range");
  }
  Execute(static_cast<TicCommand>(setup.request), CommandArgumentOf(setup));
  return 0;
}

void EmulatedTic::Execute(TicCommand command, std::uint32_t argument) {
  ++commands_received_[static_cast<std::uint8_t>(command)];
  switch (command) {
    case TicCommand::kSetTargetPosition:
      homing_ = false;
      planning_ = TicPlanningMode::kTargetPosition;
      target_ = static_cast<std::int32_t>(argument);
      break;
    case TicCommand::kSetTargetVelocity:
      // Not used by the stage; the emulated Tic holds where it is.
      Halt();
      break;
    case TicCommand::kHaltAndSetPosition:
      Halt();
      count_offset_ = static_cast<std::int32_t>(argument) - shaft_;
      target_ = static_cast<std::int32_t>(argument);
      position_uncertain_ = false;
      break;
    case TicCommand::kHaltAndHold:
      Halt();
      break;
    case TicCommand::kGoHome:
      if (argument > 1) return;  // only reverse (0) and forward (1) exist
      planning_ = TicPlanningMode::kOff;
      homing_ = true;
      homing_direction_ = static_cast<HomingDirection>(argument);
      position_uncertain_ = true;
      break;
    case TicCommand::kResetCommandTimeout:
      last_timeout_reset_ = now_;
      ClearError(TicErrorBit::kCommandTimeout);
      break;
    case TicCommand::kDeenergize:
      SetError(TicErrorBit::kIntentionallyDeenergized);
      position_uncertain_ = true;
      break;
    case TicCommand::kEnergize:
      ClearError(TicErrorBit::kIntentionallyDeenergized);
      break;
    case TicCommand::kExitSafeStart:
      ClearError(TicErrorBit::kSafeStartViolation);
      break;
    case TicCommand::kEnterSafeStart:
      SetError(TicErrorBit::kSafeStartViolation);
      break;
    case TicCommand::kReset:
      PowerUp();
      break;
    case TicCommand::kClearDriverError:
      ClearError(TicErrorBit::kMotorDriverError);
      break;
    case TicCommand::kSetMaxSpeed:
      max_speed_ = std::min(argument, kMaxSpeedUnits);
      break;
    case TicCommand::kSetStepMode:
      // A mode the product lacks is ignored.
      for (int microsteps = 1; microsteps <= MaxMicrosteps(options_.product); microsteps *= 2) {
        if (StepModeCode(microsteps) == argument) step_mode_ = static_cast<std::uint8_t>(argument);
      }
      break;
    case TicCommand::kSetStartingSpeed:
    case TicCommand::kSetMaxAccel:
    case TicCommand::kSetMaxDecel:
      break;  // the emulated Tic moves at max speed without ramps
    case TicCommand::kGetVariable:
    case TicCommand::kGetVariableAndClearErrorsOccurred:
      break;  // answered in Answer()
  }
}

}  // namespace mesocap::drivers::tic
