#include "acquisition/daemon_event_log.h"

namespace mesocap::acquisition {

std::uint64_t DaemonEventLog::Add(std::string type, nlohmann::json data) {
  std::uint64_t number = 0;
  {
    std::lock_guard lock(mutex_);
    number = ++last_;
    events_.push_back({number, std::move(type), std::move(data)});
    while (events_.size() > capacity_) events_.pop_front();
  }
  added_.notify_all();
  return number;
}

std::vector<DaemonEvent> DaemonEventLog::After(std::uint64_t after, std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  added_.wait_for(lock, timeout, [&] { return closed_ || last_ > after; });
  std::vector<DaemonEvent> out;
  if (closed_) return out;
  for (const DaemonEvent& e : events_) {
    if (e.number > after) out.push_back(e);
  }
  return out;
}

std::uint64_t DaemonEventLog::last_number() const {
  std::lock_guard lock(mutex_);
  return last_;
}

std::vector<DaemonEvent> DaemonEventLog::Latest(std::size_t count,
                                                std::initializer_list<std::string_view> types) const {
  std::lock_guard lock(mutex_);
  std::vector<DaemonEvent> out;
  for (auto e = events_.rbegin(); e != events_.rend() && out.size() < count; ++e) {
    for (const std::string_view type : types) {
      if (e->type == type) {
        out.push_back(*e);
        break;
      }
    }
  }
  return {out.rbegin(), out.rend()};
}

void DaemonEventLog::Close() {
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
  }
  added_.notify_all();
}

bool DaemonEventLog::closed() const {
  std::lock_guard lock(mutex_);
  return closed_;
}

}  // namespace mesocap::acquisition
