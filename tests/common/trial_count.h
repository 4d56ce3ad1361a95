// How many trials a randomized test runs: its default, or the count an
// environment variable gives (the sanitize preset sets smaller ones, where
// each trial costs ten to a hundred times as much).
#pragma once

#include <algorithm>
#include <cstdlib>

namespace mesocap::testing {

inline int TrialCount(const char* variable, int fallback) {
  const char* env = std::getenv(variable);
  return env ? std::max(1, std::atoi(env)) : fallback;
}

}  // namespace mesocap::testing
