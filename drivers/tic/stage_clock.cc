#include "drivers/tic/stage_clock.h"

#include <thread>

namespace mesocap::drivers::tic {

std::chrono::nanoseconds SteadyStageClock::Now() { return std::chrono::steady_clock::now().time_since_epoch(); }

void SteadyStageClock::SleepFor(std::chrono::nanoseconds duration) { std::this_thread::sleep_for(duration); }

}  // namespace mesocap::drivers::tic
