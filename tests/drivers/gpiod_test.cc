#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "drivers/device_error.h"
#include "drivers/gpiod/emulated_gpio_chip.h"
#include "drivers/gpiod/gpio_lamp_bank.h"
#include "drivers/gpiod/gpio_laser_unit.h"
#include "drivers/gpiod/libgpiod_chip.h"
#include "drivers/gpiod/step_dir_stepper.h"

#include "tests/common/no_leftovers.h"

namespace mesocap::drivers::gpiod {
namespace {

using std::chrono::milliseconds;
using std::chrono::nanoseconds;
constexpr double kPi = std::numbers::pi;
constexpr milliseconds kLong{600000};

// Time that passes only when a device sleeps, so nothing really waits.
struct FakeTime {
  nanoseconds now{0};
  GpioTiming timing() {
    return {[this](nanoseconds duration) { now += duration; }, [this] { return now; }};
  }
};

GpioLineAddress ByName(const std::string& name, bool active_low = false) { return {"gpiochip0", -1, name, active_low}; }
GpioLineAddress ByOffset(int offset, bool active_low = false) { return {"gpiochip0", offset, "", active_low}; }

// The rising edges written to `offset`.
std::vector<nanoseconds> RisingEdges(const EmulatedGpioChip& chip, int offset) {
  std::vector<nanoseconds> edges;
  bool high = false;
  for (const EmulatedGpioWrite& write : chip.writes()) {
    if (write.offset != offset) continue;
    if (write.high && !high) edges.push_back(write.time);
    high = write.high;
  }
  return edges;
}

// The message of what `call` throws as E; fails the test when it throws
// nothing or something else.
template <typename E, typename Call>
std::string MessageOf(Call call) {
  try {
    call();
  } catch (const E& error) {
    return error.what();
  } catch (const std::exception& error) {
    ADD_FAILURE() << "threw another error: " << error.what();
    return "";
  }
  ADD_FAILURE() << "threw nothing";
  return "";
}

class GpiodTest : public ::testing::Test {
 protected:
  GpiodTest()
      : chip_("gpiochip0",
              {"LAMP0", "LAMP1", "LAMP2", "SENSE0", "SENSE1", "SENSE2", "LASER_EN", "STEP", "DIR", "HOME", "", "FAN"},
              [this] { return time_.now; }) {}

  int Line(const std::string& name) const { return chip_.OffsetOf(name); }

  // Lamp 0 by offset, active-high; lamp 1 by name, active-low; lamp 2 by
  // name with a current sensor.
  GpioLampBankOptions Lamps() const {
    GpioLampBankOptions options;
    options.lamps = {
        {ByOffset(0), std::nullopt}, {ByName("LAMP1", true), std::nullopt}, {ByName("LAMP2"), ByName("SENSE2")}};
    options.settle = milliseconds(250);
    return options;
  }

  // 200 full steps x 16 microsteps x gear 3: 9600 steps a turn of the stage.
  StepDirStepperOptions Stepper() const {
    StepDirStepperOptions options;
    options.id = "tilt";
    options.step = ByName("STEP");
    options.direction = ByName("DIR");
    options.limit_switch = ByName("HOME");
    options.full_steps_per_revolution = 200;
    options.microsteps = 16;
    options.gear_ratio = 3.0;
    options.max_speed_rad_per_s = 1.0;
    options.homing_speed_rad_per_s = 0.25;
    return options;
  }

  // A motor on the step and dir lines: it turns a step a rising step edge,
  // the way the dir line says, and presses the HOME switch while within
  // `switch_width` steps above its reference (none when 0).
  void AttachMotor(std::int64_t start_steps, std::int64_t switch_width) {
    motor_steps_ = start_steps;
    chip_.OnWrite([this, switch_width](const EmulatedGpioWrite& write) {
      if (write.offset == Line("STEP") && write.high) {
        motor_steps_ += chip_.IsHigh(Line("DIR")) ? 1 : -1;
        ++motor_pulses_;
      }
      const std::int64_t at = ((motor_steps_ % 9600) + 9600) % 9600;
      chip_.Drive(Line("HOME"), at < switch_width);
    });
    chip_.Drive(Line("HOME"), ((start_steps % 9600) + 9600) % 9600 < switch_width);
  }

  FakeTime time_;
  EmulatedGpioChip chip_;
  std::int64_t motor_steps_ = 0;
  std::int64_t motor_pulses_ = 0;
};

TEST_F(GpiodTest, LampsStartOffAndSwitchWithActiveLowLevelsInverted) {
  chip_.Drive(Line("SENSE2"), true);
  GpioLampBank lamps(Lamps(), chip_.Opener(), time_.timing());
  ASSERT_EQ(lamps.lamp_count(), 3);
  EXPECT_FALSE(chip_.IsHigh(0));
  EXPECT_TRUE(chip_.IsHigh(Line("LAMP1")));  // active-low: off is high
  EXPECT_EQ(chip_.ConsumerOf(Line("LAMP1")), "mesocap");
  EXPECT_EQ(chip_.ConsumerOf(Line("SENSE2")), "mesocap");

  lamps.SetLamp(1, true);
  EXPECT_FALSE(chip_.IsHigh(Line("LAMP1")));
  EXPECT_TRUE(lamps.IsOn(1));
  EXPECT_FALSE(lamps.IsOn(0));
  lamps.SetLamp(0, true);
  EXPECT_TRUE(chip_.IsHigh(0));
  lamps.AllOff();
  EXPECT_FALSE(chip_.IsHigh(0));
  EXPECT_TRUE(chip_.IsHigh(Line("LAMP1")));
  EXPECT_FALSE(lamps.IsOn(1));
  EXPECT_THROW(lamps.SetLamp(3, true), DeviceError);
  EXPECT_THROW(lamps.IsOn(-1), DeviceError);
}

TEST_F(GpiodTest, SwitchingALampOnWaitsItsSettleTimeAndOffDoesNot) {
  chip_.Drive(Line("SENSE2"), true);
  GpioLampBank lamps(Lamps(), chip_.Opener(), time_.timing());
  chip_.ClearWrites();
  time_.now = milliseconds(1000);
  lamps.SetLamp(2, true);
  EXPECT_EQ(time_.now, milliseconds(1250));
  ASSERT_EQ(chip_.writes().size(), 1u);
  EXPECT_EQ(chip_.writes()[0].time, milliseconds(1000));
  lamps.SetLamp(2, true);  // already on: no second warm-up
  EXPECT_EQ(time_.now, milliseconds(1250));
  lamps.SetLamp(2, false);
  EXPECT_EQ(time_.now, milliseconds(1250));
}

TEST_F(GpiodTest, ALampWhoseSensorReadsNoCurrentIsBurntOut) {
  GpioLampBank lamps(Lamps(), chip_.Opener(), time_.timing());
  const std::string message = MessageOf<LampFailureError>([&] { lamps.SetLamp(2, true); });
  EXPECT_NE(message.find("lamp 2 does not light"), std::string::npos) << message;
  EXPECT_NE(message.find("GPIO gpiochip0 line \"SENSE2\""), std::string::npos) << message;
  // Switched off again, not left on to heat a broken socket.
  EXPECT_FALSE(lamps.IsOn(2));
  EXPECT_FALSE(chip_.IsHigh(Line("LAMP2")));
}

TEST_F(GpiodTest, LinesAreReleasedAndLampsOffWhenTheBankIsDestroyed) {
  {
    GpioLampBank lamps(Lamps(), chip_.Opener(), time_.timing());
    lamps.SetLamp(0, true);
    lamps.SetLamp(1, true);
    EXPECT_TRUE(chip_.IsRequested(0));
  }
  for (const char* line : {"LAMP0", "LAMP1", "LAMP2", "SENSE2"}) EXPECT_FALSE(chip_.IsRequested(Line(line))) << line;
  EXPECT_EQ(chip_.ConsumerOf(0), "");
  EXPECT_FALSE(chip_.IsHigh(0));
  EXPECT_TRUE(chip_.IsHigh(Line("LAMP1")));
  GpioLampBank again(Lamps(), chip_.Opener(), time_.timing());
  EXPECT_TRUE(chip_.IsRequested(0));
}

TEST_F(GpiodTest, ABusyLineIsNamedWithItsConsumer) {
  chip_.HoldFor(Line("LAMP1"), "gpio-fan");
  const std::string message =
      MessageOf<DeviceError>([&] { GpioLampBank lamps(Lamps(), chip_.Opener(), time_.timing()); });
  EXPECT_EQ(message, "GPIO gpiochip0 line \"LAMP1\": in use by \"gpio-fan\" (Device or resource busy)");
  // What the failed bank had requested is free again.
  EXPECT_FALSE(chip_.IsRequested(0));

  GpioLampBank first(GpioLampBankOptions{{{ByOffset(0), std::nullopt}}}, chip_.Opener(), time_.timing());
  const std::string second = MessageOf<DeviceError>([&] {
    GpioLampBank lamps(GpioLampBankOptions{{{ByOffset(0), std::nullopt}}}, chip_.Opener());
  });
  EXPECT_EQ(second, "GPIO gpiochip0 line 0: in use by \"mesocap\" (Device or resource busy)");
}

TEST_F(GpiodTest, MissingLinesAndChipsAreNamed) {
  GpioLampBankOptions options;
  options.lamps = {{ByName("LAMP9"), std::nullopt}};
  EXPECT_EQ(MessageOf<DeviceError>([&] { GpioLampBank lamps(options, chip_.Opener()); }),
            "GPIO gpiochip0 line \"LAMP9\": no line of that name on the chip");
  options.lamps = {{ByOffset(40), std::nullopt}};
  EXPECT_EQ(MessageOf<DeviceError>([&] { GpioLampBank lamps(options, chip_.Opener()); }),
            "GPIO gpiochip0 line 40: no such line (the chip has 12 lines)");
  options.lamps = {{{"gpiochip7", 0, "", false}, std::nullopt}};
  EXPECT_EQ(MessageOf<DeviceError>([&] { GpioLampBank lamps(options, chip_.Opener()); }),
            "GPIO chip \"gpiochip7\": cannot open: No such file or directory; chips here: gpiochip0 [emulated]");
  // By path, as the rig description may give it.
  options.lamps = {{{"/dev/gpiochip0", 0, "", false}, std::nullopt}};
  EXPECT_NO_THROW(GpioLampBank(options, chip_.Opener(), time_.timing()));
}

TEST_F(GpiodTest, OptionsCheckNamesTheField) {
  EXPECT_EQ(Lamps().Check(), "");
  EXPECT_EQ(GpioLampBankOptions{}.Check(), "lamps: none (one power line a lamp)");
  GpioLampBankOptions lamps = Lamps();
  lamps.lamps[2].sense = ByOffset(0);
  EXPECT_EQ(lamps.Check(), "lamps[2].sense: GPIO gpiochip0 line 0 is already lamps[0].power");
  lamps.lamps[2].sense = GpioLineAddress{"gpiochip0", -1, "", false};
  EXPECT_EQ(lamps.Check(), "lamps[2].sense.line: neither an offset nor a name");
  EXPECT_THROW(GpioLampBank(lamps, chip_.Opener()), DeviceError);

  EXPECT_EQ(Stepper().Check(), "");
  StepDirStepperOptions stepper = Stepper();
  stepper.microsteps = 0;
  EXPECT_EQ(stepper.Check(), "microsteps: 0 (1 to 256)");
  stepper = Stepper();
  stepper.limit_switch = stepper.step;
  EXPECT_EQ(stepper.Check(), "limit_switch: GPIO gpiochip0 line \"STEP\" is already step");
  stepper = Stepper();
  stepper.max_speed_rad_per_s = 200.0;  // 1.5 M steps/s: 654 ns a step
  EXPECT_NE(stepper.Check().find("shorter than twice step_pulse"), std::string::npos) << stepper.Check();
  stepper = Stepper();
  stepper.homing_speed_rad_per_s = 2.0;
  EXPECT_NE(stepper.Check().find("homing_speed_rad_per_s"), std::string::npos);

  GpioLaserOptions laser{ByName("LASER_EN"), 0.5, 3, 3};
  EXPECT_EQ(laser.Check(), "mount: 3 (the arc has mounts 0 to 2)");
}

TEST_F(GpiodTest, StepperHomesOnTheLimitSwitchEdge) {
  AttachMotor(/*start_steps=*/100, /*switch_width=*/5);
  StepDirStepper stage(Stepper(), chip_.Opener(), time_.timing());
  EXPECT_FALSE(stage.IsHomed());
  EXPECT_THROW(stage.MoveTo(1.0), DeviceError);
  stage.Home();
  EXPECT_TRUE(stage.IsHomed());
  EXPECT_EQ(motor_steps_, 4);  // the first step on the switch, coming down
  EXPECT_EQ(motor_pulses_, 96);
  EXPECT_EQ(stage.position_steps(), 0);
  EXPECT_DOUBLE_EQ(stage.Position(), 0.0);
  // At the homing speed: 0.25 rad/s at 9600 / 2 pi steps a radian.
  const std::vector<nanoseconds> edges = RisingEdges(chip_, Line("STEP"));
  ASSERT_EQ(edges.size(), 96u);
  const nanoseconds period = edges[1] - edges[0];
  EXPECT_NEAR(static_cast<double>(period.count()), 1e9 / (0.25 * 9600 / (2 * kPi)), 1.0);
  EXPECT_EQ(edges.back() - edges[0], 95 * period);
}

TEST_F(GpiodTest, StepperStartingOnTheSwitchLeavesItFirst) {
  AttachMotor(/*start_steps=*/2, /*switch_width=*/5);
  StepDirStepper stage(Stepper(), chip_.Opener(), time_.timing());
  stage.Home();
  // Up off the switch (to 5), then down onto its edge (4).
  EXPECT_EQ(motor_steps_, 4);
  EXPECT_EQ(motor_pulses_, 3 + 1);
}

TEST_F(GpiodTest, AMissingSwitchEdgeWithinOneTurnIsAStall) {
  AttachMotor(/*start_steps=*/100, /*switch_width=*/0);
  StepDirStepper stage(Stepper(), chip_.Opener(), time_.timing());
  const std::string message = MessageOf<StallError>([&] { stage.Home(); });
  EXPECT_EQ(message, "tilt: limit switch GPIO gpiochip0 line \"HOME\" did not switch within one turn (9600 steps)");
  EXPECT_EQ(motor_pulses_, 9600);
  EXPECT_FALSE(stage.IsHomed());
}

TEST_F(GpiodTest, StepperPulsesCountMicrostepsAndGearAndDirection) {
  AttachMotor(/*start_steps=*/0, /*switch_width=*/5);
  StepDirStepper stage(Stepper(), chip_.Opener(), time_.timing());
  stage.Home();  // already on the switch: leaves it and comes back, at step 4
  const std::int64_t home = motor_steps_;

  chip_.ClearWrites();
  stage.MoveTo(kPi / 2);
  EXPECT_TRUE(stage.IsMoving());
  stage.WaitUntilStopped(kLong);
  EXPECT_FALSE(stage.IsMoving());
  EXPECT_EQ(motor_steps_ - home, 2400);  // a quarter of 200 x 16 x 3
  EXPECT_TRUE(chip_.IsHigh(Line("DIR")));
  EXPECT_NEAR(stage.Position(), kPi / 2, 1e-12);
  // The dir line was set before the first step, by the setup time.
  const std::vector<nanoseconds> edges = RisingEdges(chip_, Line("STEP"));
  ASSERT_EQ(edges.size(), 2400u);
  ASSERT_EQ(chip_.writes().front().offset, Line("DIR"));
  EXPECT_GE(edges.front() - chip_.writes().front().time, Stepper().direction_setup);
  // At the maximum speed, 1 rad/s.
  EXPECT_NEAR(static_cast<double>((edges[1] - edges[0]).count()), 1e9 / (9600 / (2 * kPi)), 1.0);

  // Back, the other way.
  stage.MoveTo(kPi / 4);
  stage.WaitUntilStopped(kLong);
  EXPECT_EQ(motor_steps_ - home, 1200);
  EXPECT_FALSE(chip_.IsHigh(Line("DIR")));

  // Across the reference the shorter way: down 1200 + 480 steps, not up.
  stage.MoveTo(2 * kPi - 2 * kPi / 20);
  stage.WaitUntilStopped(kLong);
  EXPECT_EQ(motor_steps_ - home, -480);
  EXPECT_NEAR(stage.Position(), 2 * kPi - 2 * kPi / 20, 1e-12);
}

TEST_F(GpiodTest, AMoveLongerThanTheTimeoutGoesOnAtTheNextWait) {
  AttachMotor(/*start_steps=*/10, /*switch_width=*/5);
  StepDirStepper stage(Stepper(), chip_.Opener(), time_.timing());
  stage.Home();
  const std::int64_t home = motor_steps_;
  stage.MoveTo(kPi);  // 4800 steps: 3.14 s at 1 rad/s
  EXPECT_THROW(stage.WaitUntilStopped(milliseconds(1000)), TimeoutError);
  EXPECT_TRUE(stage.IsMoving());
  EXPECT_GT(motor_steps_ - home, 1500);
  EXPECT_LT(motor_steps_ - home, 1600);
  stage.WaitUntilStopped(kLong);
  EXPECT_FALSE(stage.IsMoving());
  EXPECT_EQ(motor_steps_ - home, 4800);
}

TEST_F(GpiodTest, LaserEnablesTiltsAndKeepsItsMount) {
  AttachMotor(/*start_steps=*/50, /*switch_width=*/5);
  {
    auto stage = std::make_unique<StepDirStepper>(Stepper(), chip_.Opener(), time_.timing());
    GpioLaserUnit laser(GpioLaserOptions{ByName("LASER_EN", true), 0.5, 3, 1}, chip_.Opener(), std::move(stage));
    EXPECT_TRUE(chip_.IsHigh(Line("LASER_EN")));  // active-low: off
    EXPECT_FALSE(laser.IsEnabled());
    laser.SetEnabled(true);
    EXPECT_TRUE(laser.IsEnabled());
    EXPECT_FALSE(chip_.IsHigh(Line("LASER_EN")));

    laser.SetTilt(-0.25, kLong);  // homes first
    EXPECT_NEAR(laser.Tilt(), -0.25, 1e-3);
    EXPECT_LT(motor_steps_, 0);
    laser.SetTilt(0.3, kLong);
    EXPECT_NEAR(laser.Tilt(), 0.3, 1e-3);
    EXPECT_THROW(laser.SetTilt(0.6, kLong), DeviceError);

    EXPECT_EQ(laser.mount_count(), 3);
    EXPECT_EQ(laser.mount(), 1);
    laser.SetMount(2);
    EXPECT_EQ(laser.mount(), 2);
    EXPECT_THROW(laser.SetMount(3), DeviceError);
  }
  EXPECT_TRUE(chip_.IsHigh(Line("LASER_EN")));  // off again
  EXPECT_FALSE(chip_.IsRequested(Line("LASER_EN")));
  EXPECT_FALSE(chip_.IsRequested(Line("STEP")));
}

TEST_F(GpiodTest, AVanishedChipDisconnectsEveryDevice) {
  chip_.Drive(Line("SENSE2"), true);
  AttachMotor(/*start_steps=*/10, /*switch_width=*/5);
  auto lamps = std::make_unique<GpioLampBank>(Lamps(), chip_.Opener(), time_.timing());
  StepDirStepper stage(Stepper(), chip_.Opener(), time_.timing());
  stage.Home();
  lamps->SetLamp(0, true);
  chip_.Vanish();

  EXPECT_EQ(MessageOf<DisconnectedError>([&] { lamps->SetLamp(1, true); }),
            "GPIO gpiochip0 line \"LAMP1\": cannot set the value: No such device (the chip is gone)");
  stage.MoveTo(1.0);
  EXPECT_THROW(stage.WaitUntilStopped(kLong), DisconnectedError);
  EXPECT_FALSE(stage.IsHomed());  // whether the motor moved is unknown
  EXPECT_THROW(stage.Home(), DisconnectedError);
  EXPECT_NO_THROW(lamps.reset());
  EXPECT_THROW(GpioLampBank(Lamps(), chip_.Opener()), DeviceError);
}

TEST(GpiodTimingTest, RealTimingSleepsOnTheSteadyClock) {
  const GpioTiming timing = GpioTiming::Real();
  const nanoseconds before = timing.now();
  timing.sleep(milliseconds(2));
  EXPECT_GE(timing.now() - before, milliseconds(2));
}

// This machine's kernel through the real libgpiod: the tests run where there
// are no GPIO chips, and a rig with the GPIO backend must say so clearly.
TEST(GpiodLibgpiodChipTest, AMissingChipIsNamedWithTheChipsThereAre) {
  if (!ListLibgpiodChips().empty()) GTEST_SKIP() << "this machine has GPIO chips";
  const std::string expected = "GPIO chip \"gpiochip0\": cannot open: No such file or directory; chips here: none";
  EXPECT_EQ(MessageOf<DeviceError>([] { OpenLibgpiodChip("gpiochip0"); }), expected);

  GpioLampBankOptions options;
  options.lamps = {{{"gpiochip0", 3, "", false}, std::nullopt}};
  EXPECT_EQ(MessageOf<DeviceError>([&] { GpioLampBank lamps(options, LibgpiodChipOpener()); }), expected);
  EXPECT_THROW(OpenLibgpiodChip("/dev/gpiochip0"), DeviceError);
}

// No process or socket outlives the tests (tests/common/no_leftovers.h).
::testing::Environment* const kNoLeftovers = ::testing::AddGlobalTestEnvironment(new ::mesocap::testing::NoLeftovers);

}  // namespace
}  // namespace mesocap::drivers::gpiod
