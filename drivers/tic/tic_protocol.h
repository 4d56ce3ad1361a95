// The Pololu Tic's native USB protocol: command codes, the variables block,
// error bits and products, and the pure functions that turn a command into a
// control transfer's setup packet and the variables block into a struct.
//
// Where the facts come from (repository pololu/pololu-tic-software: headers in
// include/, sources in lib/):
// - Pololu's tic_protocol.h: the vendor and product ids, command codes,
//   variable offsets, error bits, operation states, misc flags bits
//   (energized 0, position uncertain 1, forward/reverse limit 2/3, homing
//   active 4), step mode codes, go-home directions, speed units (steps per
//   10000 s, at most 500000000), acceleration units (steps/s per 100 s),
//   default command timeout 1000 ms. The stored
//   copy of that file predates go home, the T249/36v4 ids and the homing
//   bits; those were read from the same file as vendored in
//   indilib/indi-3rdparty (indi-TicFocuser-ng/pololu-tic-software/include/)
//   and agree with tic_handle.c, tic_device.c, tic_variables.c.
// - tic_handle.c: a command is a vendor control transfer (bmRequestType
//   0x40) with a 32-bit argument split into wValue (low half) and wIndex
//   (high half), a 7-bit argument in wValue, and no data stage; variables
//   are read with bmRequestType 0xC0, the offset in wIndex, the length in
//   wLength; go home takes its direction in wValue.
// - tic_internal.h: multi-byte variables are little-endian.
// - tic_variables.c: the general variables block ends after "input
//   after scaling" (offset 0x51 + 4).
// - tic_device.c, tic_names.c: which product ids are Tics, their
//   names, and the error names.
// - tic_settings_fix.c: which step modes each product allows.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace mesocap::drivers::tic {

inline constexpr std::uint16_t kPololuVendorId = 0x1FFB;

enum class TicProduct { kT825, kT834, kT500, kN825, kT249, k36v4 };

// Every Tic product, for enumeration and for messages.
inline constexpr TicProduct kTicProducts[] = {TicProduct::kT825, TicProduct::kT834, TicProduct::kT500,
                                              TicProduct::kN825, TicProduct::kT249, TicProduct::k36v4};

std::uint16_t UsbProductId(TicProduct product);
// The product with this USB product id (under kPololuVendorId), if a Tic.
std::optional<TicProduct> ProductFromUsbId(std::uint16_t product_id);
// "Tic T825 Stepper Motor Controller".
std::string ProductName(TicProduct product);
// The finest microstepping the product's driver offers (T500: 8, 36v4: 256).
int MaxMicrosteps(TicProduct product);
// The "set step mode" code of `microsteps` per full step (1, 2, 4 ... 256);
// nullopt for a count the Tic has no mode for.
std::optional<std::uint8_t> StepModeCode(int microsteps);

enum class TicCommand : std::uint8_t {
  kSetTargetPosition = 0xE0,
  kSetTargetVelocity = 0xE3,
  kHaltAndSetPosition = 0xEC,
  kHaltAndHold = 0x89,
  kGoHome = 0x97,
  kResetCommandTimeout = 0x8C,
  kDeenergize = 0x86,
  kEnergize = 0x85,
  kExitSafeStart = 0x83,
  kEnterSafeStart = 0x8F,
  kReset = 0xB0,
  kClearDriverError = 0x8A,
  kSetMaxSpeed = 0xE6,
  kSetStartingSpeed = 0xE5,
  kSetMaxAccel = 0xEA,
  kSetMaxDecel = 0xE9,
  kSetStepMode = 0x94,
  kGetVariable = 0xA1,
  kGetVariableAndClearErrorsOccurred = 0xA2,
};

// Byte offsets in the variables block.
namespace variable_offset {
inline constexpr std::uint8_t kOperationState = 0x00;
inline constexpr std::uint8_t kMiscFlags1 = 0x01;
inline constexpr std::uint8_t kErrorStatus = 0x02;     // u16
inline constexpr std::uint8_t kErrorsOccurred = 0x04;  // u32
inline constexpr std::uint8_t kPlanningMode = 0x09;
inline constexpr std::uint8_t kTargetPosition = 0x0A;        // i32
inline constexpr std::uint8_t kTargetVelocity = 0x0E;        // i32
inline constexpr std::uint8_t kStartingSpeed = 0x12;         // u32
inline constexpr std::uint8_t kMaxSpeed = 0x16;              // u32
inline constexpr std::uint8_t kMaxDecel = 0x1A;              // u32
inline constexpr std::uint8_t kMaxAccel = 0x1E;              // u32
inline constexpr std::uint8_t kCurrentPosition = 0x22;       // i32
inline constexpr std::uint8_t kCurrentVelocity = 0x26;       // i32
inline constexpr std::uint8_t kActingTargetPosition = 0x2A;  // i32
inline constexpr std::uint8_t kTimeSinceLastStep = 0x2E;     // u32
inline constexpr std::uint8_t kDeviceReset = 0x32;
inline constexpr std::uint8_t kVinVoltage = 0x33;  // u16, mV
inline constexpr std::uint8_t kUpTime = 0x35;      // u32, ms
inline constexpr std::uint8_t kStepMode = 0x49;
inline constexpr std::uint8_t kInputAfterScaling = 0x51;  // i32, the last general variable
}  // namespace variable_offset

// The general variables block that every Tic answers.
inline constexpr std::size_t kVariablesBlockSize = variable_offset::kInputAfterScaling + 4;

// Bits of misc flags 1.
namespace misc_flag {
inline constexpr int kEnergized = 0;
inline constexpr int kPositionUncertain = 1;
inline constexpr int kForwardLimitActive = 2;
inline constexpr int kReverseLimitActive = 3;
inline constexpr int kHomingActive = 4;
}  // namespace misc_flag

// Bit numbers in "error status" (errors stopping the motor now) and
// "errors occurred" (latched since last cleared).
enum class TicErrorBit : int {
  kIntentionallyDeenergized = 0,
  kMotorDriverError = 1,
  kLowVin = 2,
  kKillSwitch = 3,
  kRequiredInputInvalid = 4,
  kSerialError = 5,
  kCommandTimeout = 6,
  kSafeStartViolation = 7,
  kErrLineHigh = 8,
  kSerialFraming = 16,
  kSerialRxOverrun = 17,
  kSerialFormat = 18,
  kSerialCrc = 19,
  kEncoderSkip = 20,
};

constexpr std::uint32_t ErrorMask(TicErrorBit bit) { return std::uint32_t{1} << static_cast<int>(bit); }
// Pololu's name of the error ("Low VIN").
std::string ErrorName(TicErrorBit bit);
// The names of the errors set in `bits`, comma-separated ("Low VIN, Command
// timeout"); unknown bits as "error bit N"; "" when none.
std::string DescribeErrors(std::uint32_t bits);

enum class TicOperationState : std::uint8_t {
  kReset = 0,
  kDeenergized = 2,
  kSoftError = 4,
  kWaitingForErrLine = 6,
  kStartingUp = 8,
  kNormal = 10,
};
std::string OperationStateName(std::uint8_t state);

enum class TicPlanningMode : std::uint8_t { kOff = 0, kTargetPosition = 1, kTargetVelocity = 2 };

// The go-home command's argument.
enum class HomingDirection : std::uint8_t { kReverse = 0, kForward = 1 };

// Speeds are in microsteps per 10000 s; the Tic takes at most 50 kHz.
inline constexpr double kSpeedUnitsPerStepPerSecond = 10000.0;
// Accelerations are in microsteps per second per 100 s.
inline constexpr double kAccelUnitsPerStepPerSecondSquared = 100.0;
inline constexpr std::uint32_t kMaxSpeedUnits = 500000000;
inline constexpr int kDefaultCommandTimeoutMs = 1000;

// The setup packet of a USB control transfer (USB 2.0 Sec. 9.3).
struct ControlSetup {
  std::uint8_t request_type = 0;
  std::uint8_t request = 0;
  std::uint16_t value = 0;
  std::uint16_t index = 0;
  std::uint16_t length = 0;

  bool operator==(const ControlSetup&) const = default;
};

inline constexpr std::uint8_t kVendorHostToDevice = 0x40;
inline constexpr std::uint8_t kVendorDeviceToHost = 0xC0;

// How a command carries its argument.
enum class CommandArgument { kNone, kSevenBit, kThirtyTwoBit, kReadsData };
// nullopt for a request code this library does not know.
std::optional<CommandArgument> ArgumentOf(std::uint8_t request);

// The setup packet of a host-to-device command. `argument` is the 32-bit
// value (a position or speed; a negative position as its two's complement),
// the 7-bit value (step mode, homing direction), or ignored. Throws
// std::invalid_argument for a get-variable command or a 7-bit argument
// above 127.
ControlSetup EncodeCommand(TicCommand command, std::uint32_t argument = 0);
ControlSetup EncodeSetTargetPosition(std::int32_t microsteps);
ControlSetup EncodeHaltAndSetPosition(std::int32_t microsteps);
ControlSetup EncodeGoHome(HomingDirection direction);
// The setup packet that reads `length` bytes of variables from `offset`.
ControlSetup EncodeGetVariables(std::uint8_t offset, std::uint16_t length, bool clear_errors_occurred);
// A 32-bit argument as the command carries it (the reverse of EncodeCommand).
std::uint32_t CommandArgumentOf(const ControlSetup& setup);

struct TicVariables {
  std::uint8_t operation_state = 0;
  bool energized = false;
  bool position_uncertain = false;
  bool forward_limit_active = false;
  bool reverse_limit_active = false;
  bool homing_active = false;
  std::uint16_t error_status = 0;
  std::uint32_t errors_occurred = 0;
  std::uint8_t planning_mode = 0;
  std::int32_t target_position = 0;
  std::int32_t target_velocity = 0;
  std::uint32_t starting_speed = 0;
  std::uint32_t max_speed = 0;
  std::uint32_t max_decel = 0;
  std::uint32_t max_accel = 0;
  std::int32_t current_position = 0;
  std::int32_t current_velocity = 0;
  std::int32_t acting_target_position = 0;
  std::uint32_t time_since_last_step = 0;
  std::uint8_t device_reset = 0;
  std::uint16_t vin_voltage_mv = 0;
  std::uint32_t up_time_ms = 0;
  std::uint8_t step_mode = 0;

  bool operator==(const TicVariables&) const = default;
};

// Decodes the general variables block. Throws std::invalid_argument when
// `block` is shorter than kVariablesBlockSize.
TicVariables DecodeVariables(std::span<const std::uint8_t> block);
// The block a Tic would answer for `variables` (what an emulated Tic sends).
std::vector<std::uint8_t> EncodeVariables(const TicVariables& variables);

}  // namespace mesocap::drivers::tic
