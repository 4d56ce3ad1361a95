// The message of the error a call throws, for tests that check what an error
// names.
#pragma once

#include <gtest/gtest.h>

#include <string>

#include "core/error.h"

namespace mesocap::testing {

// Returns the message of the error (of type E) `f` throws; fails if it throws none.
template <typename E = core::Error, typename F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error thrown";
  return {};
}

}  // namespace mesocap::testing
