// The Pololu Tic backend: the protocol's encoding against the numbers in
// Pololu's own source, the emulated Tic, the stage over it in emulated time,
// and libusb on a machine without a Tic.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>
#include <stdexcept>

#include "drivers/device_error.h"
#include "drivers/tic/emulated_tic.h"
#include "drivers/tic/libusb_tic_transport.h"
#include "drivers/tic/tic_protocol.h"
#include "drivers/tic/tic_rotary_stage.h"
#include "tests/common/error_of.h"
#include "tests/common/no_leftovers.h"

namespace mesocap::drivers::tic {
namespace {

using namespace std::chrono_literals;
using testing::ErrorOf;
constexpr double kPi = std::numbers::pi;

// ---- Protocol: expected numbers from pololu/pololu-tic-software ----

TEST(TicProtocolTest, CommandCodesAreThoseOfPololusProtocolHeader) {
  // Pololu's tic_protocol.h, TIC_CMD_*.
  const std::pair<TicCommand, int> expected[] = {
      {TicCommand::kSetTargetPosition, 0xE0},
      {TicCommand::kSetTargetVelocity, 0xE3},
      {TicCommand::kHaltAndSetPosition, 0xEC},
      {TicCommand::kHaltAndHold, 0x89},
      {TicCommand::kGoHome, 0x97},
      {TicCommand::kResetCommandTimeout, 0x8C},
      {TicCommand::kDeenergize, 0x86},
      {TicCommand::kEnergize, 0x85},
      {TicCommand::kExitSafeStart, 0x83},
      {TicCommand::kEnterSafeStart, 0x8F},
      {TicCommand::kReset, 0xB0},
      {TicCommand::kClearDriverError, 0x8A},
      {TicCommand::kSetMaxSpeed, 0xE6},
      {TicCommand::kSetStartingSpeed, 0xE5},
      {TicCommand::kSetMaxAccel, 0xEA},
      {TicCommand::kSetMaxDecel, 0xE9},
      {TicCommand::kSetStepMode, 0x94},
      {TicCommand::kGetVariable, 0xA1},
      {TicCommand::kGetVariableAndClearErrorsOccurred, 0xA2},
  };
  for (const auto& [command, code] : expected) EXPECT_EQ(static_cast<int>(command), code);
}

TEST(TicProtocolTest, CommandsWithoutArgumentAreBareVendorRequests) {
  // Pololu's tic_handle.c: bmRequestType 0x40, wValue 0, wIndex 0, no data.
  for (TicCommand command :
       {TicCommand::kHaltAndHold, TicCommand::kResetCommandTimeout, TicCommand::kDeenergize, TicCommand::kEnergize,
        TicCommand::kExitSafeStart, TicCommand::kEnterSafeStart, TicCommand::kReset, TicCommand::kClearDriverError}) {
    EXPECT_EQ(EncodeCommand(command), (ControlSetup{0x40, static_cast<std::uint8_t>(command), 0, 0, 0}));
  }
}

TEST(TicProtocolTest, ThirtyTwoBitArgumentsSplitIntoValueAndIndex) {
  // Pololu's tic_handle.c: wValue = low 16 bits, wIndex = high 16 bits.
  EXPECT_EQ(EncodeSetTargetPosition(0x12345678), (ControlSetup{0x40, 0xE0, 0x5678, 0x1234, 0}));
  EXPECT_EQ(EncodeSetTargetPosition(-2), (ControlSetup{0x40, 0xE0, 0xFFFE, 0xFFFF, 0}));
  EXPECT_EQ(EncodeHaltAndSetPosition(0), (ControlSetup{0x40, 0xEC, 0, 0, 0}));
  EXPECT_EQ(EncodeHaltAndSetPosition(-100000), (ControlSetup{0x40, 0xEC, 0x7960, 0xFFFE, 0}));
  // 2000000 = 0x001E8480: 200 steps/s in the Tic's units of steps per 10000 s.
  EXPECT_EQ(EncodeCommand(TicCommand::kSetMaxSpeed, 2000000), (ControlSetup{0x40, 0xE6, 0x8480, 0x001E, 0}));
  EXPECT_EQ(EncodeCommand(TicCommand::kSetTargetVelocity, 0xFFFFFFFF), (ControlSetup{0x40, 0xE3, 0xFFFF, 0xFFFF, 0}));
  EXPECT_EQ(CommandArgumentOf(EncodeSetTargetPosition(-123456)), static_cast<std::uint32_t>(-123456));
}

TEST(TicProtocolTest, SevenBitArgumentsGoInValue) {
  // Pololu's tic_handle.c: set step mode and go home put their byte in wValue;
  // Pololu's tic_protocol.h: TIC_GO_HOME_REVERSE 0, TIC_GO_HOME_FORWARD 1.
  EXPECT_EQ(EncodeGoHome(HomingDirection::kReverse), (ControlSetup{0x40, 0x97, 0, 0, 0}));
  EXPECT_EQ(EncodeGoHome(HomingDirection::kForward), (ControlSetup{0x40, 0x97, 1, 0, 0}));
  EXPECT_EQ(EncodeCommand(TicCommand::kSetStepMode, 3), (ControlSetup{0x40, 0x94, 3, 0, 0}));
  EXPECT_THROW(EncodeCommand(TicCommand::kSetStepMode, 128), std::invalid_argument);
  EXPECT_THROW(EncodeCommand(TicCommand::kGetVariable), std::invalid_argument);
}

TEST(TicProtocolTest, StepModeCodes) {
  // Pololu's tic_protocol.h: TIC_STEP_MODE_MICROSTEP1..32 = 0..5,
  // MICROSTEP2_100P = 6, MICROSTEP64/128/256 = 7/8/9.
  const std::pair<int, int> expected[] = {{1, 0},  {2, 1},  {4, 2},   {8, 3},  {16, 4},
                                          {32, 5}, {64, 7}, {128, 8}, {256, 9}};
  for (const auto& [microsteps, code] : expected) EXPECT_EQ(StepModeCode(microsteps), code) << microsteps;
  EXPECT_FALSE(StepModeCode(3));
  EXPECT_FALSE(StepModeCode(512));
  // Pololu's tic_settings_fix.c: the T500 goes to 1/8, the 36v4 to 1/256.
  EXPECT_EQ(MaxMicrosteps(TicProduct::kT500), 8);
  EXPECT_EQ(MaxMicrosteps(TicProduct::kT825), 32);
  EXPECT_EQ(MaxMicrosteps(TicProduct::k36v4), 256);
}

TEST(TicProtocolTest, GetVariablesReadsFromOffsetInIndex) {
  // Pololu's tic_handle.c: bmRequestType 0xC0, wValue 0, wIndex = offset, wLength.
  EXPECT_EQ(EncodeGetVariables(0, 0x55, false), (ControlSetup{0xC0, 0xA1, 0, 0, 0x55}));
  EXPECT_EQ(EncodeGetVariables(0x22, 4, true), (ControlSetup{0xC0, 0xA2, 0, 0x22, 4}));
}

TEST(TicProtocolTest, UsbIdsAndProductNames) {
  // Pololu's tic_protocol.h TIC_VENDOR_ID, TIC_PRODUCT_ID_*; tic_names.c.
  EXPECT_EQ(kPololuVendorId, 0x1FFB);
  EXPECT_EQ(ProductFromUsbId(0x00B3), TicProduct::kT825);
  EXPECT_EQ(ProductFromUsbId(0x00B5), TicProduct::kT834);
  EXPECT_EQ(ProductFromUsbId(0x00BD), TicProduct::kT500);
  EXPECT_EQ(ProductFromUsbId(0x00C3), TicProduct::kN825);
  EXPECT_EQ(ProductFromUsbId(0x00C9), TicProduct::kT249);
  EXPECT_EQ(ProductFromUsbId(0x00CB), TicProduct::k36v4);
  EXPECT_FALSE(ProductFromUsbId(0x00B4));
  for (TicProduct product : kTicProducts) EXPECT_EQ(ProductFromUsbId(UsbProductId(product)), product);
  EXPECT_EQ(ProductName(TicProduct::k36v4), "Tic 36v4 High-Power Stepper Motor Controller");
}

TEST(TicProtocolTest, VariableOffsetsAndFlags) {
  // Pololu's tic_protocol.h TIC_VAR_*, TIC_MISC_FLAGS1_*; tic_variables.c
  // reads the general block up to TIC_VAR_INPUT_AFTER_SCALING + 4.
  namespace at = variable_offset;
  EXPECT_EQ(at::kOperationState, 0x00);
  EXPECT_EQ(at::kMiscFlags1, 0x01);
  EXPECT_EQ(at::kErrorStatus, 0x02);
  EXPECT_EQ(at::kErrorsOccurred, 0x04);
  EXPECT_EQ(at::kPlanningMode, 0x09);
  EXPECT_EQ(at::kTargetPosition, 0x0A);
  EXPECT_EQ(at::kTargetVelocity, 0x0E);
  EXPECT_EQ(at::kMaxSpeed, 0x16);
  EXPECT_EQ(at::kCurrentPosition, 0x22);
  EXPECT_EQ(at::kCurrentVelocity, 0x26);
  EXPECT_EQ(at::kVinVoltage, 0x33);
  EXPECT_EQ(at::kStepMode, 0x49);
  EXPECT_EQ(kVariablesBlockSize, 0x55u);
  EXPECT_EQ(misc_flag::kEnergized, 0);
  EXPECT_EQ(misc_flag::kPositionUncertain, 1);
  EXPECT_EQ(misc_flag::kHomingActive, 4);
  // TIC_OPERATION_STATE_*; TIC_DEFAULT_COMMAND_TIMEOUT; TIC_SPEED_UNITS_PER_HZ.
  EXPECT_EQ(static_cast<int>(TicOperationState::kSoftError), 4);
  EXPECT_EQ(static_cast<int>(TicOperationState::kNormal), 10);
  EXPECT_EQ(OperationStateName(6), "waiting for ERR line");
  EXPECT_EQ(kDefaultCommandTimeoutMs, 1000);
  EXPECT_EQ(kSpeedUnitsPerStepPerSecond, 10000.0);
}

TEST(TicProtocolTest, ErrorBitsAndNames) {
  // Pololu's tic_protocol.h TIC_ERROR_*; tic_names.c tic_error_names_ui.
  EXPECT_EQ(ErrorMask(TicErrorBit::kIntentionallyDeenergized), 1u << 0);
  EXPECT_EQ(ErrorMask(TicErrorBit::kMotorDriverError), 1u << 1);
  EXPECT_EQ(ErrorMask(TicErrorBit::kLowVin), 1u << 2);
  EXPECT_EQ(ErrorMask(TicErrorBit::kKillSwitch), 1u << 3);
  EXPECT_EQ(ErrorMask(TicErrorBit::kRequiredInputInvalid), 1u << 4);
  EXPECT_EQ(ErrorMask(TicErrorBit::kSerialError), 1u << 5);
  EXPECT_EQ(ErrorMask(TicErrorBit::kCommandTimeout), 1u << 6);
  EXPECT_EQ(ErrorMask(TicErrorBit::kSafeStartViolation), 1u << 7);
  EXPECT_EQ(ErrorMask(TicErrorBit::kErrLineHigh), 1u << 8);
  EXPECT_EQ(ErrorMask(TicErrorBit::kEncoderSkip), 1u << 20);
  EXPECT_EQ(DescribeErrors(1u << 2 | 1u << 6), "Low VIN, Command timeout");
  EXPECT_EQ(DescribeErrors(1u << 8 | 1u << 12), "ERR line high, error bit 12");
  EXPECT_EQ(DescribeErrors(0), "");
}

TEST(TicProtocolTest, DecodesLittleEndianVariables) {
  // Pololu's tic_internal.h read_u16/read_u32: little-endian.
  std::array<std::uint8_t, kVariablesBlockSize> block{};
  block[0x00] = 10;       // normal
  block[0x01] = 0b10011;  // energized, position uncertain, homing active
  block[0x02] = 0x44;     // low VIN | command timeout
  block[0x0A] = 0xFE, block[0x0B] = 0xFF, block[0x0C] = 0xFF, block[0x0D] = 0xFF;  // target -2
  block[0x22] = 0x78, block[0x23] = 0x56, block[0x24] = 0x34, block[0x25] = 0x12;  // current 0x12345678
  block[0x33] = 0xE0, block[0x34] = 0x2E;                                          // VIN 12000 mV
  const TicVariables v = DecodeVariables(block);
  EXPECT_EQ(v.operation_state, 10);
  EXPECT_TRUE(v.energized);
  EXPECT_TRUE(v.position_uncertain);
  EXPECT_FALSE(v.forward_limit_active);
  EXPECT_TRUE(v.homing_active);
  EXPECT_EQ(v.error_status, 0x44);
  EXPECT_EQ(v.target_position, -2);
  EXPECT_EQ(v.current_position, 0x12345678);
  EXPECT_EQ(v.vin_voltage_mv, 12000);
  EXPECT_EQ(DecodeVariables(EncodeVariables(v)), v);
  EXPECT_THROW(DecodeVariables(std::span(block).first(0x20)), std::invalid_argument);
}

// ---- The emulated Tic on its own ----

std::uint16_t ErrorStatusOf(EmulatedTic& tic) {
  std::array<std::uint8_t, 2> status{};
  auto transport = tic.Open();
  transport->ControlTransfer(EncodeGetVariables(variable_offset::kErrorStatus, 2, false), status);
  return static_cast<std::uint16_t>(status[0] | status[1] << 8);
}

TEST(EmulatedTicTest, RejectsWhatARealTicWouldStall) {
  EmulatedTic tic({});
  auto transport = tic.Open();
  std::array<std::uint8_t, 8> data{};
  EXPECT_NE(ErrorOf<DeviceError>([&] {
              transport->ControlTransfer({0x40, 0x42, 0, 0, 0}, data);
            }).find("pipe error"),
            std::string::npos);
  // A read sent as a write, a read past the block, an argument to a bare command.
  EXPECT_THROW(transport->ControlTransfer({0x40, 0xA1, 0, 0, 4}, data), DeviceError);
  EXPECT_THROW(transport->ControlTransfer(EncodeGetVariables(0x54, 4, false), data), DeviceError);
  EXPECT_THROW(transport->ControlTransfer({0x40, 0x8C, 1, 0, 0}, data), DeviceError);
}

TEST(EmulatedTicTest, StartsInSafeStartAndTimesOutWithoutKeepalive) {
  EmulatedTic tic({});
  EXPECT_EQ(ErrorStatusOf(tic), ErrorMask(TicErrorBit::kSafeStartViolation));
  auto transport = tic.Open();
  transport->ControlTransfer(EncodeCommand(TicCommand::kResetCommandTimeout), {});
  transport->ControlTransfer(EncodeCommand(TicCommand::kExitSafeStart), {});
  EXPECT_EQ(ErrorStatusOf(tic), 0);
  // Polling alone does not count: only "reset command timeout" does.
  for (int i = 0; i < 10; ++i) {
    tic.Advance(90ms);
    ErrorStatusOf(tic);
  }
  EXPECT_EQ(ErrorStatusOf(tic), 0);
  tic.Advance(200ms);
  EXPECT_EQ(ErrorStatusOf(tic), ErrorMask(TicErrorBit::kCommandTimeout) | ErrorMask(TicErrorBit::kSafeStartViolation));
}

// ---- The stage over the emulated Tic ----

// A 200-step motor at 1/8 microstepping, direct drive: 1600 microsteps a
// turn; the home switch 400 microsteps forward of where it powered up.
EmulatedTicOptions TicOptions() {
  EmulatedTicOptions options;
  options.serial_number = "00200001";
  options.home_switch_microsteps = 400;
  options.revolution_microsteps = 1600;
  options.homing_speed = 8000000;  // 800 microsteps/s
  return options;
}

TicStageOptions StageOptions() {
  TicStageOptions options;
  options.id = "turntable";
  options.serial_number = "00200001";
  options.microsteps = 8;
  options.max_speed_rad_per_s = kPi;  // half a turn a second
  return options;
}

constexpr double kMicrostepRad = 2 * kPi / 1600;

// Moves and waits; the stage must stand within a microstep of the angle.
void MoveAndWait(TicRotaryStage& stage, double angle_rad) {
  stage.MoveTo(angle_rad);
  stage.WaitUntilStopped(10s);
  EXPECT_NEAR(stage.Position(), angle_rad, kMicrostepRad);
}

class TicStageTest : public ::testing::Test {
 protected:
  std::unique_ptr<TicRotaryStage> MakeStage(TicStageOptions options = StageOptions()) {
    return std::make_unique<TicRotaryStage>(options, tic_.Opener(), tic_.MakeClock());
  }

  EmulatedTic tic_{TicOptions()};
};

TEST_F(TicStageTest, HomesToTheSwitchWithGoHome) {
  auto stage = MakeStage();
  EXPECT_FALSE(stage->IsHomed());
  EXPECT_THROW(stage->MoveTo(1.0), DeviceError);
  stage->Home();
  EXPECT_TRUE(stage->IsHomed());
  EXPECT_EQ(tic_.commands_received(TicCommand::kGoHome), 1);
  // Reverse from 0: the switch one revolution back, at 400 - 1600.
  EXPECT_DOUBLE_EQ(tic_.shaft_microsteps(), -1200.0);
  EXPECT_NEAR(stage->Position(), 0.0, 1e-12);
  EXPECT_FALSE(tic_.Variables().position_uncertain);
  EXPECT_EQ(tic_.Variables().step_mode, 3);         // 1/8
  EXPECT_EQ(tic_.Variables().max_speed, 8000000u);  // 800 microsteps/s = pi rad/s
}

TEST_F(TicStageTest, HomesForward) {
  TicStageOptions options = StageOptions();
  options.homing_direction = HomingDirection::kForward;
  auto stage = MakeStage(options);
  stage->Home();
  EXPECT_DOUBLE_EQ(tic_.shaft_microsteps(), 400.0);
}

TEST_F(TicStageTest, MovesToAnAngleTheShorterWay) {
  auto stage = MakeStage();
  stage->Home();
  const double home_shaft = tic_.shaft_microsteps();
  stage->MoveTo(kPi / 2);
  EXPECT_TRUE(stage->IsMoving());
  stage->WaitUntilStopped(5s);
  EXPECT_FALSE(stage->IsMoving());
  EXPECT_NEAR(stage->Position(), kPi / 2, 1e-12);
  EXPECT_DOUBLE_EQ(tic_.shaft_microsteps() - home_shaft, 400.0);
  // Across 0: from pi/2 to 7/4 pi turns back 3/4 pi, not forward 5/4 pi.
  stage->MoveTo(1.75 * kPi);
  stage->WaitUntilStopped(5s);
  EXPECT_NEAR(stage->Position(), 1.75 * kPi, 1e-12);
  EXPECT_DOUBLE_EQ(tic_.shaft_microsteps() - home_shaft, -200.0);
  // And forward across 0 again: 7/4 pi to 1/4 pi is +1/2 pi.
  stage->MoveTo(0.25 * kPi);
  stage->WaitUntilStopped(5s);
  EXPECT_DOUBLE_EQ(tic_.shaft_microsteps() - home_shaft, 200.0);
}

TEST_F(TicStageTest, GearRatioAndMicrosteppingRoundTrip) {
  TicStageOptions options = StageOptions();
  options.microsteps = 16;
  options.gear_ratio = 3.5;  // 200 * 16 * 3.5 = 11200 microsteps a turn
  auto stage = MakeStage(options);
  stage->Home();
  EXPECT_EQ(tic_.Variables().step_mode, 4);  // 1/16
  for (double angle : {0.1, 1.0, 3.0, 6.2, 0.0, 4.5}) {
    stage->MoveTo(angle);
    stage->WaitUntilStopped(10s);
    EXPECT_NEAR(stage->Position(), angle, kPi / 11200) << angle;
    const double expected_count = std::round(angle / (2 * kPi) * 11200);
    const double count = tic_.Variables().current_position;
    EXPECT_EQ(std::fmod(count - expected_count, 11200.0), 0.0) << angle;
  }
}

TEST_F(TicStageTest, StallIsAStallError) {
  auto stage = MakeStage();
  stage->Home();
  stage->MoveTo(kPi);
  tic_.Advance(300ms);
  tic_.Stall(true);
  EXPECT_NE(ErrorOf<StallError>([&] { stage->WaitUntilStopped(10s); }).find("turntable"), std::string::npos);
  EXPECT_FALSE(stage->IsHomed());
  EXPECT_LT(tic_.now(), 3s);  // found within the motion time plus margin
}

TEST_F(TicStageTest, MotorHaltedShortOfTargetIsAStallError) {
  auto stage = MakeStage();
  stage->Home();
  stage->MoveTo(kPi);
  tic_.Advance(300ms);
  tic_.Open()->ControlTransfer(EncodeCommand(TicCommand::kHaltAndHold), {});
  EXPECT_THROW(stage->WaitUntilStopped(10s), StallError);
}

TEST_F(TicStageTest, VanishedTicIsDisconnectedAndReopenRecovers) {
  auto stage = MakeStage();
  stage->Home();
  stage->MoveTo(kPi);
  tic_.Advance(200ms);
  tic_.Unplug();
  EXPECT_THROW(stage->WaitUntilStopped(5s), DisconnectedError);
  EXPECT_THROW(stage->Position(), DisconnectedError);
  EXPECT_EQ(ErrorOf<DeviceError>([&] { stage->Reopen(); }), "no Tic with serial 00200001 found (found: none)");
  EXPECT_THROW(stage->Position(), DisconnectedError);
  // Back on the bus, still powered: it kept its count, so it stays homed.
  tic_.PlugIn(false);
  stage->Reopen();
  EXPECT_TRUE(stage->IsHomed());
  MoveAndWait(*stage, kPi);
}

TEST_F(TicStageTest, PowerCycledTicMustBeHomedAgain) {
  auto stage = MakeStage();
  stage->Home();
  tic_.Unplug();
  tic_.PlugIn(true);
  EXPECT_THROW(stage->MoveTo(1.0), DisconnectedError);
  stage->Reopen();
  EXPECT_FALSE(stage->IsHomed());
  EXPECT_THROW(stage->MoveTo(1.0), DeviceError);
  stage->Home();
  MoveAndWait(*stage, 1.0);
}

TEST_F(TicStageTest, TimeoutsAreTimeoutErrors) {
  auto stage = MakeStage();
  stage->Home();
  stage->MoveTo(kPi);  // one second
  EXPECT_THROW(stage->WaitUntilStopped(200ms), TimeoutError);
  stage->WaitUntilStopped(5s);  // the move went on
  EXPECT_NEAR(stage->Position(), kPi, 1e-12);
  tic_.FailNextTransfersWithTimeout(1);
  EXPECT_THROW(stage->Position(), TimeoutError);
  EXPECT_NEAR(stage->Position(), kPi, 1e-12);
}

TEST_F(TicStageTest, KeepsTheCommandTimeoutAliveDuringALongMove) {
  TicStageOptions options = StageOptions();
  options.max_speed_rad_per_s = kPi / 4;  // the half turn takes 4 s
  auto stage = MakeStage(options);
  stage->Home();
  const int resets_before = tic_.commands_received(TicCommand::kResetCommandTimeout);
  stage->MoveTo(kPi);
  stage->WaitUntilStopped(10s);
  EXPECT_NEAR(stage->Position(), kPi, 1e-12);
  EXPECT_EQ(tic_.Variables().errors_occurred & ErrorMask(TicErrorBit::kCommandTimeout), 0u);
  EXPECT_GE(tic_.commands_received(TicCommand::kResetCommandTimeout) - resets_before, 8);
}

TEST_F(TicStageTest, WithoutKeepaliveTheTicStopsWithCommandTimeout) {
  // The stage believes the Tic waits 10 s; it waits 1 s.
  TicStageOptions options = StageOptions();
  options.max_speed_rad_per_s = kPi / 4;
  options.command_timeout = 10s;
  options.keepalive_period = 5s;
  options.homing_direction = HomingDirection::kForward;  // half a second: done before the Tic times out
  auto stage = MakeStage(options);
  stage->Home();
  stage->MoveTo(kPi);
  EXPECT_NE(ErrorOf<DeviceError>([&] { stage->WaitUntilStopped(10s); }).find("Command timeout"), std::string::npos);
}

TEST_F(TicStageTest, IdleCommandTimeoutIsClearedByTheNextMove) {
  auto stage = MakeStage();
  stage->Home();
  tic_.Advance(5s);  // the capture takes its images; nobody talks to the Tic
  EXPECT_NE(tic_.Variables().error_status & ErrorMask(TicErrorBit::kCommandTimeout), 0);
  MoveAndWait(*stage, 1.0);
}

TEST_F(TicStageTest, LowVinIsADeviceErrorNamingTheBit) {
  auto stage = MakeStage();
  stage->Home();
  stage->MoveTo(kPi);
  tic_.Advance(200ms);
  tic_.LoseMotorPower();
  try {
    stage->WaitUntilStopped(5s);
    ADD_FAILURE() << "no error";
  } catch (const StallError& e) {
    ADD_FAILURE() << "a lost supply is not a stall: " << e.what();
  } catch (const DeviceError& e) {
    EXPECT_NE(std::string(e.what()).find("Low VIN"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(stage->IsHomed());
  tic_.RestoreMotorPower();
  EXPECT_THROW(stage->MoveTo(1.0), DeviceError);  // position uncertain: home first
  stage->Home();
  MoveAndWait(*stage, 1.0);
}

TEST_F(TicStageTest, RefusesAnotherProduct) {
  TicStageOptions options = StageOptions();
  options.product = TicProduct::k36v4;
  EXPECT_NE(ErrorOf<DeviceError>([&] { MakeStage(options); }).find("Tic T825"), std::string::npos);
}

TEST(TicStageOptionsTest, Check) {
  EXPECT_EQ(StageOptions().Check(), "");
  TicStageOptions options = StageOptions();
  options.microsteps = 64;
  EXPECT_EQ(options.Check(), "Tic T825 Stepper Motor Controller offers at most 32 microsteps, not 64");
  options.product = TicProduct::k36v4;
  options.microsteps = 256;
  EXPECT_EQ(options.Check(), "");
  options = StageOptions();
  options.microsteps = 3;
  EXPECT_NE(options.Check().find("power of two"), std::string::npos);
  options = StageOptions();
  options.serial_number = "";
  EXPECT_NE(options.Check().find("serial_number"), std::string::npos);
  options = StageOptions();
  options.keepalive_period = 600ms;
  EXPECT_NE(options.Check().find("half of command_timeout"), std::string::npos);
  options = StageOptions();
  options.max_speed_rad_per_s = 1000.0;  // 254648 steps/s
  EXPECT_NE(options.Check().find("50000 steps/s"), std::string::npos);
  options = StageOptions();
  options.gear_ratio = 0.0;
  EXPECT_NE(options.Check().find("gear_ratio"), std::string::npos);
}

// ---- libusb on this machine: no Tic plugged in ----

TEST(LibusbTicTest, FindsNoTicAndNamesTheSerialItCannotOpen) {
  const std::vector<TicDeviceInfo> tics = ListLibusbTics();
  if (!tics.empty()) GTEST_SKIP() << "a Tic is plugged in: " << Describe(tics.front());
  EXPECT_EQ(ErrorOf<DeviceError>([] { OpenLibusbTic("00123456"); }), "no Tic with serial 00123456 found (found: none)");
}

TEST(LibusbTicTest, MapsLibusbErrors) {
  // libusb.h: LIBUSB_ERROR_NO_DEVICE -4, LIBUSB_ERROR_TIMEOUT -7,
  // LIBUSB_ERROR_PIPE -9, LIBUSB_ERROR_OTHER -99.
  EXPECT_THROW(ThrowLibusbError(-4, "x"), DisconnectedError);
  EXPECT_THROW(ThrowLibusbError(-7, "x"), TimeoutError);
  const std::string pipe = ErrorOf<DeviceError>([] { ThrowLibusbError(-9, "Tic 1 request 0x42"); });
  EXPECT_EQ(pipe.rfind("Tic 1 request 0x42: ", 0), 0u) << pipe;
  try {
    ThrowLibusbError(-9, "x");
  } catch (const TimeoutError&) {
    ADD_FAILURE() << "a pipe error is no timeout";
  } catch (const DisconnectedError&) {
    ADD_FAILURE() << "a pipe error is no disconnect";
  } catch (const DeviceError&) {
  }
  const std::string start = LibusbStartFailure(-99);
  EXPECT_NE(start.find("libusb could not start"), std::string::npos) << start;
  EXPECT_NE(start.find("/dev/bus/usb"), std::string::npos) << start;
}

// No process or socket outlives the tests (tests/common/no_leftovers.h).
::testing::Environment* const kNoLeftovers = ::testing::AddGlobalTestEnvironment(new ::mesocap::testing::NoLeftovers);

}  // namespace
}  // namespace mesocap::drivers::tic
