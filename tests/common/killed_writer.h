// What the tests of killed writers share: a process id that no longer
// exists, and a count of what looks like a temporary under a folder.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <string>

namespace mesocap::testing {

// The id of a process that has exited (a writer killed mid-write).
inline long DeadPid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ::waitpid(child, nullptr, 0);
  return child;
}

// Entries anywhere under `dir` whose name holds ".tmp-" (".name.tmp-PID-N...").
inline int CountTemporaries(const std::filesystem::path& dir) {
  int n = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    n += e.path().filename().string().find(".tmp-") != std::string::npos;
  }
  return n;
}

}  // namespace mesocap::testing
