// What a device test may leave behind: nothing. A test binary that starts
// servers (served cameras, arv-fake-gv-camera-0.8, mesocap processes)
// includes this header once: after its tests have run (ctest runs one test
// a process), the process has no child process left, running or a zombie,
// and no socket open that it did not have before its first test. Read from
// /proc (Linux).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <sstream>
#include <string>
#include <system_error>

namespace mesocap::testing {

// The inodes of this process's open sockets ("socket:[N]" links in /proc/self/fd).
inline std::set<std::string> OpenSockets() {
  std::set<std::string> sockets;
  std::error_code ec;
  for (const auto& fd : std::filesystem::directory_iterator("/proc/self/fd", ec)) {
    const std::string target = std::filesystem::read_symlink(fd.path(), ec).string();
    if (!ec && target.rfind("socket:", 0) == 0) sockets.insert(target);
  }
  return sockets;
}

// The pids whose parent is this process (field 4 of /proc/PID/stat).
inline std::set<int> ChildProcesses() {
  std::set<int> children;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream stat(entry.path() / "stat");
    std::string line;
    if (!std::getline(stat, line)) continue;
    // "pid (comm) state ppid ...": comm may hold spaces, so read after ')'.
    const std::size_t close = line.rfind(')');
    if (close == std::string::npos) continue;
    std::istringstream rest(line.substr(close + 1));
    std::string state;
    int ppid = 0;
    if (rest >> state >> ppid && ppid == ::getpid()) children.insert(std::stoi(name));
  }
  return children;
}

class NoLeftovers : public ::testing::Environment {
 public:
  // `release` runs before the check: a library's own process-wide state
  // that outlives every test by design (Aravis' interface list) is let go.
  explicit NoLeftovers(std::function<void()> release = {}) : release_(std::move(release)) {}
  void SetUp() override { sockets_before_ = OpenSockets(); }
  void TearDown() override {
    if (release_) release_();
    for (const int pid : ChildProcesses()) ADD_FAILURE() << "a child process is left behind: pid " << pid;
    for (const std::string& socket : OpenSockets()) {
      if (!sockets_before_.count(socket)) ADD_FAILURE() << "a socket is left open: " << socket;
    }
  }

 private:
  std::function<void()> release_;
  std::set<std::string> sockets_before_;
};

}  // namespace mesocap::testing
