// The capture daemon's events (job state changes, steps, faults) as a
// numbered, bounded log: clients of the event stream ask for what came after
// the last number they saw and wait for more. Old events fall off the end,
// so a slow or stalled client never grows the daemon's memory.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <initializer_list>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace mesocap::acquisition {

struct DaemonEvent {
  std::uint64_t number = 0;  // from 1, in order
  std::string type;          // "job", "step", "fault", "log"
  nlohmann::json data;
};

class DaemonEventLog {
 public:
  explicit DaemonEventLog(std::size_t capacity = 1024) : capacity_(capacity) {}

  std::uint64_t Add(std::string type, nlohmann::json data);
  // The events numbered after `after` that are still held, waiting up to
  // `timeout` for one when there is none yet. Returns early, empty, after
  // Close().
  std::vector<DaemonEvent> After(std::uint64_t after, std::chrono::milliseconds timeout);
  std::uint64_t last_number() const;
  // The latest `count` events still held whose type is one of `types`,
  // oldest first; never waits.
  std::vector<DaemonEvent> Latest(std::size_t count, std::initializer_list<std::string_view> types) const;
  // Wakes every waiter for good (the daemon is stopping).
  void Close();
  bool closed() const;

 private:
  const std::size_t capacity_;
  mutable std::mutex mutex_;
  std::condition_variable added_;
  std::deque<DaemonEvent> events_;
  std::uint64_t last_ = 0;
  bool closed_ = false;
};

}  // namespace mesocap::acquisition
