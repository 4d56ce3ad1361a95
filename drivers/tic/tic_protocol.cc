#include "drivers/tic/tic_protocol.h"

#include <stdexcept>

namespace mesocap::drivers::tic {
namespace {

struct ProductFacts {
  TicProduct product;
  std::uint16_t usb_product_id;
  const char* name;
  int max_microsteps;
};

constexpr ProductFacts kProductFacts[] = {
    {TicProduct::kT825, 0x00B3, "Tic T825 Stepper Motor Controller", 32},
    {TicProduct::kT834, 0x00B5, "Tic T834 Stepper Motor Controller", 32},
    {TicProduct::kT500, 0x00BD, "Tic T500 Stepper Motor Controller", 8},
    {TicProduct::kN825, 0x00C3, "Tic N825 Stepper Motor Controller", 32},
    {TicProduct::kT249, 0x00C9, "Tic T249 Stepper Motor Controller", 32},
    {TicProduct::k36v4, 0x00CB, "Tic 36v4 High-Power Stepper Motor Controller", 256},
};

const ProductFacts& FactsOf(TicProduct product) {
  for (const ProductFacts& facts : kProductFacts) {
    if (facts.product == product) return facts;
  }
  throw std::invalid_argument("unknown Tic product");
}

struct ErrorFacts {
  TicErrorBit bit;
  const char* name;
};

constexpr ErrorFacts kErrorFacts[] = {
    {TicErrorBit::kIntentionallyDeenergized, "Intentionally de-energized"},
    {TicErrorBit::kMotorDriverError, "Motor driver error"},
    {TicErrorBit::kLowVin, "Low VIN"},
    {TicErrorBit::kKillSwitch, "Kill switch active"},
    {TicErrorBit::kRequiredInputInvalid, "Required input invalid"},
    {TicErrorBit::kSerialError, "Serial error"},
    {TicErrorBit::kCommandTimeout, "Command timeout"},
    {TicErrorBit::kSafeStartViolation, "Safe start violation"},
    {TicErrorBit::kErrLineHigh, "ERR line high"},
    {TicErrorBit::kSerialFraming, "Serial framing"},
    {TicErrorBit::kSerialRxOverrun, "Serial RX overrun"},
    {TicErrorBit::kSerialFormat, "Serial format"},
    {TicErrorBit::kSerialCrc, "Serial CRC"},
    {TicErrorBit::kEncoderSkip, "Encoder skip"},
};

std::uint32_t ReadU32(std::span<const std::uint8_t> block, std::size_t offset) {
  return std::uint32_t{block[offset]} | std::uint32_t{block[offset + 1]} << 8 | std::uint32_t{block[offset + 2]} << 16 |
         std::uint32_t{block[offset + 3]} << 24;
}

std::uint16_t ReadU16(std::span<const std::uint8_t> block, std::size_t offset) {
  return static_cast<std::uint16_t>(block[offset] | block[offset + 1] << 8);
}

void WriteU32(std::vector<std::uint8_t>& block, std::size_t offset, std::uint32_t value) {
  for (int i = 0; i < 4; ++i) block[offset + i] = static_cast<std::uint8_t>(value >> (8 * i));
}

void WriteU16(std::vector<std::uint8_t>& block, std::size_t offset, std::uint16_t value) {
  block[offset] = static_cast<std::uint8_t>(value);
  block[offset + 1] = static_cast<std::uint8_t>(value >> 8);
}

}  // namespace

std::uint16_t UsbProductId(TicProduct product) { return FactsOf(product).usb_product_id; }

std::optional<TicProduct> ProductFromUsbId(std::uint16_t product_id) {
  for (const ProductFacts& facts : kProductFacts) {
    if (facts.usb_product_id == product_id) return facts.product;
  }
  return std::nullopt;
}

std::string ProductName(TicProduct product) { return FactsOf(product).name; }

int MaxMicrosteps(TicProduct product) { return FactsOf(product).max_microsteps; }

std::optional<std::uint8_t> StepModeCode(int microsteps) {
  // Codes 0-5 are 1-32 microsteps; 6 is the T249's "2 (100%)" mode, so the
  // 36v4's 64-256 continue at 7.
  switch (microsteps) {
    case 1:
      return 0;
    case 2:
      return 1;
    case 4:
      return 2;
    case 8:
      return 3;
    case 16:
      return 4;
    case 32:
      return 5;
    case 64:
      return 7;
    case 128:
      return 8;
    case 256:
      return 9;
    default:
      return std::nullopt;
  }
}

std::string ErrorName(TicErrorBit bit) {
  for (const ErrorFacts& facts : kErrorFacts) {
    if (facts.bit == bit) return facts.name;
  }
  return "error bit " + std::to_string(static_cast<int>(bit));
}

std::string DescribeErrors(std::uint32_t bits) {
  std::string names;
  for (int bit = 0; bit < 32; ++bit) {
    if (!(bits >> bit & 1)) continue;
    if (!names.empty()) names += ", ";
    names += ErrorName(static_cast<TicErrorBit>(bit));
  }
  return names;
}

std::string OperationStateName(std::uint8_t state) {
  switch (static_cast<TicOperationState>(state)) {
    case TicOperationState::kReset:
      return "reset";
    case TicOperationState::kDeenergized:
      return "de-energized";
    case TicOperationState::kSoftError:
      return "soft error";
    case TicOperationState::kWaitingForErrLine:
      return "waiting for ERR line";
    case TicOperationState::kStartingUp:
      return "starting up";
    case TicOperationState::kNormal:
      return "normal";
  }
  return "unknown operation state " + std::to_string(state);
}

std::optional<CommandArgument> ArgumentOf(std::uint8_t request) {
  switch (static_cast<TicCommand>(request)) {
    case TicCommand::kHaltAndHold:
    case TicCommand::kResetCommandTimeout:
    case TicCommand::kDeenergize:
    case TicCommand::kEnergize:
    case TicCommand::kExitSafeStart:
    case TicCommand::kEnterSafeStart:
    case TicCommand::kReset:
    case TicCommand::kClearDriverError:
      return CommandArgument::kNone;
    case TicCommand::kGoHome:
    case TicCommand::kSetStepMode:
      return CommandArgument::kSevenBit;
    case TicCommand::kSetTargetPosition:
    case TicCommand::kSetTargetVelocity:
    case TicCommand::kHaltAndSetPosition:
    case TicCommand::kSetMaxSpeed:
    case TicCommand::kSetStartingSpeed:
    case TicCommand::kSetMaxAccel:
    case TicCommand::kSetMaxDecel:
      return CommandArgument::kThirtyTwoBit;
    case TicCommand::kGetVariable:
    case TicCommand::kGetVariableAndClearErrorsOccurred:
      return CommandArgument::kReadsData;
  }
  return std::nullopt;
}

ControlSetup EncodeCommand(TicCommand command, std::uint32_t argument) {
  ControlSetup setup;
  setup.request_type = kVendorHostToDevice;
  setup.request = static_cast<std::uint8_t>(command);
  switch (*ArgumentOf(setup.request)) {
    case CommandArgument::kNone:
      break;
    case CommandArgument::kSevenBit:
      if (argument > 0x7F) throw std::invalid_argument("a 7-bit Tic command argument above 127");
      setup.value = static_cast<std::uint16_t>(argument);
      break;
    case CommandArgument::kThirtyTwoBit:
      setup.value = static_cast<std::uint16_t>(argument & 0xFFFF);
      setup.index = static_cast<std::uint16_t>(argument >> 16);
      break;
    case CommandArgument::kReadsData:
      throw std::invalid_argument("get variable is a read: use EncodeGetVariables");
  }
  return setup;
}

ControlSetup EncodeSetTargetPosition(std::int32_t microsteps) {
  return EncodeCommand(TicCommand::kSetTargetPosition, static_cast<std::uint32_t>(microsteps));
}

ControlSetup EncodeHaltAndSetPosition(std::int32_t microsteps) {
  return EncodeCommand(TicCommand::kHaltAndSetPosition, static_cast<std::uint32_t>(microsteps));
}

ControlSetup EncodeGoHome(HomingDirection direction) {
  return EncodeCommand(TicCommand::kGoHome, static_cast<std::uint32_t>(direction));
}

ControlSetup EncodeGetVariables(std::uint8_t offset, std::uint16_t length, bool clear_errors_occurred) {
  ControlSetup setup;
  setup.request_type = kVendorDeviceToHost;
  setup.request = static_cast<std::uint8_t>(clear_errors_occurred ? TicCommand::kGetVariableAndClearErrorsOccurred
                                                                  : TicCommand::kGetVariable);
  setup.index = offset;
  setup.length = length;
  return setup;
}

std::uint32_t CommandArgumentOf(const ControlSetup& setup) {
  return std::uint32_t{setup.value} | std::uint32_t{setup.index} << 16;
}

TicVariables DecodeVariables(std::span<const std::uint8_t> block) {
  if (block.size() < kVariablesBlockSize) {
    throw std::invalid_argument("Tic variables block of " + std::to_string(block.size()) + " bytes, needs " +
                                std::to_string(kVariablesBlockSize));
  }
  namespace at = variable_offset;
  TicVariables v;
  v.operation_state = block[at::kOperationState];
  const std::uint8_t flags = block[at::kMiscFlags1];
  v.energized = flags >> misc_flag::kEnergized & 1;
  v.position_uncertain = flags >> misc_flag::kPositionUncertain & 1;
  v.forward_limit_active = flags >> misc_flag::kForwardLimitActive & 1;
  v.reverse_limit_active = flags >> misc_flag::kReverseLimitActive & 1;
  v.homing_active = flags >> misc_flag::kHomingActive & 1;
  v.error_status = ReadU16(block, at::kErrorStatus);
  v.errors_occurred = ReadU32(block, at::kErrorsOccurred);
  v.planning_mode = block[at::kPlanningMode];
  v.target_position = static_cast<std::int32_t>(ReadU32(block, at::kTargetPosition));
  v.target_velocity = static_cast<std::int32_t>(ReadU32(block, at::kTargetVelocity));
  v.starting_speed = ReadU32(block, at::kStartingSpeed);
  v.max_speed = ReadU32(block, at::kMaxSpeed);
  v.max_decel = ReadU32(block, at::kMaxDecel);
  v.max_accel = ReadU32(block, at::kMaxAccel);
  v.current_position = static_cast<std::int32_t>(ReadU32(block, at::kCurrentPosition));
  v.current_velocity = static_cast<std::int32_t>(ReadU32(block, at::kCurrentVelocity));
  v.acting_target_position = static_cast<std::int32_t>(ReadU32(block, at::kActingTargetPosition));
  v.time_since_last_step = ReadU32(block, at::kTimeSinceLastStep);
  v.device_reset = block[at::kDeviceReset];
  v.vin_voltage_mv = ReadU16(block, at::kVinVoltage);
  v.up_time_ms = ReadU32(block, at::kUpTime);
  v.step_mode = block[at::kStepMode];
  return v;
}

std::vector<std::uint8_t> EncodeVariables(const TicVariables& v) {
  namespace at = variable_offset;
  std::vector<std::uint8_t> block(kVariablesBlockSize, 0);
  block[at::kOperationState] = v.operation_state;
  block[at::kMiscFlags1] = static_cast<std::uint8_t>(
      v.energized << misc_flag::kEnergized | v.position_uncertain << misc_flag::kPositionUncertain |
      v.forward_limit_active << misc_flag::kForwardLimitActive |
      v.reverse_limit_active << misc_flag::kReverseLimitActive | v.homing_active << misc_flag::kHomingActive);
  WriteU16(block, at::kErrorStatus, v.error_status);
  WriteU32(block, at::kErrorsOccurred, v.errors_occurred);
  block[at::kPlanningMode] = v.planning_mode;
  WriteU32(block, at::kTargetPosition, static_cast<std::uint32_t>(v.target_position));
  WriteU32(block, at::kTargetVelocity, static_cast<std::uint32_t>(v.target_velocity));
  WriteU32(block, at::kStartingSpeed, v.starting_speed);
  WriteU32(block, at::kMaxSpeed, v.max_speed);
  WriteU32(block, at::kMaxDecel, v.max_decel);
  WriteU32(block, at::kMaxAccel, v.max_accel);
  WriteU32(block, at::kCurrentPosition, static_cast<std::uint32_t>(v.current_position));
  WriteU32(block, at::kCurrentVelocity, static_cast<std::uint32_t>(v.current_velocity));
  WriteU32(block, at::kActingTargetPosition, static_cast<std::uint32_t>(v.acting_target_position));
  WriteU32(block, at::kTimeSinceLastStep, v.time_since_last_step);
  block[at::kDeviceReset] = v.device_reset;
  WriteU16(block, at::kVinVoltage, v.vin_voltage_mv);
  WriteU32(block, at::kUpTime, v.up_time_ms);
  block[at::kStepMode] = v.step_mode;
  return block;
}

}  // namespace mesocap::drivers::tic
