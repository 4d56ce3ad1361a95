// Tests that run a binary as a child process they can kill at any moment
// (kill -9 trials): fork and exec with output to a file, and the exit code.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace mesocap::testing {

// Starts `binary` with `args`, stdout and stderr appended to `log`; returns its pid.
inline pid_t StartProcess(const char* binary, const std::vector<std::string>& args,
                          const std::filesystem::path& log = "/dev/null") {
  const pid_t pid = ::fork();
  if (pid == 0) {
    std::vector<char*> argv{const_cast<char*>(binary)};
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (std::freopen(log.c_str(), "a", stdout) == nullptr || std::freopen(log.c_str(), "a", stderr) == nullptr) {
      ::_exit(126);
    }
    ::execv(binary, argv.data());
    ::_exit(127);
  }
  return pid;
}

// The child's exit code, or -1 when a signal ended it.
inline int WaitForExit(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace mesocap::testing
