// Runs the real `mesocap` binary (MESOCAP_BINARY, set by the test's CMake
// target) as a user would, capturing its exit code, stdout and stderr.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/common/file_bytes.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::testing {

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

// `env` prefixes the command line (e.g. "env -u DISPLAY", "MESOCAP_CACHE_DIR=...").
inline CommandResult Mesocap(const std::string& args, const std::string& env = "") {
  TemporaryDirectory dir;
  const std::string cmd = env + " " + std::string(MESOCAP_BINARY) + " " + args + " >" + (dir / "out").string() + " 2>" +
                          (dir / "err").string();
  const int status = std::system(cmd.c_str());
  CommandResult r;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = Slurp(dir / "out");
  r.err = Slurp(dir / "err");
  return r;
}

// The CLI's way to refuse: one line on stderr, "mesocap: error: LINE", exit 1.
inline void ExpectOneErrorLine(const CommandResult& r, const std::string& line) {
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err, "mesocap: error: " + line + "\n");
}

}  // namespace mesocap::testing
