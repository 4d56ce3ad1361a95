// The time a stage polls by, so that tests run a stage in emulated time
// (EmulatedTic's clock) while the rig runs it in real time.
#pragma once

#include <chrono>

namespace mesocap::drivers::tic {

class StageClock {
 public:
  virtual ~StageClock() = default;
  // Time since an arbitrary start; never goes back.
  virtual std::chrono::nanoseconds Now() = 0;
  virtual void SleepFor(std::chrono::nanoseconds duration) = 0;
};

// std::chrono::steady_clock and std::this_thread::sleep_for.
class SteadyStageClock : public StageClock {
 public:
  std::chrono::nanoseconds Now() override;
  void SleepFor(std::chrono::nanoseconds duration) override;
};

}  // namespace mesocap::drivers::tic
