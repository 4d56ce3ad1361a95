#include "acquisition/connection_watch.h"

#include <sys/socket.h>

namespace mesocap::acquisition {

void ConnectionWatch::Close(Connection& c) {
  ::shutdown(c.fd, SHUT_RDWR);
  c.closing = true;
}

void ConnectionWatch::Opened(const void* connection, int fd) {
  const Clock::time_point now = Clock::now();
  std::lock_guard lock(mutex_);
  Connection* oldest = nullptr;
  std::size_t waiting = 0;
  for (auto& [key, c] : connections_) {
    if (!c.waiting || c.closing) continue;
    ++waiting;
    if (oldest == nullptr || c.since < oldest->since) oldest = &c;
  }
  if (waiting >= max_waiting_ && oldest != nullptr) Close(*oldest);
  connections_[connection] = Connection{fd, true, false, now};
}

void ConnectionWatch::Answering(const void* connection) {
  std::lock_guard lock(mutex_);
  if (const auto it = connections_.find(connection); it != connections_.end()) it->second.waiting = false;
}

void ConnectionWatch::Answered(const void* connection) {
  const Clock::time_point now = Clock::now();
  std::lock_guard lock(mutex_);
  if (const auto it = connections_.find(connection); it != connections_.end()) {
    it->second.waiting = true;
    it->second.since = now;
  }
}

void ConnectionWatch::Closed(const void* connection) {
  std::lock_guard lock(mutex_);
  connections_.erase(connection);
}

void ConnectionWatch::CloseOverdue(Clock::time_point now) {
  std::lock_guard lock(mutex_);
  for (auto& [key, c] : connections_) {
    if (c.waiting && !c.closing && now - c.since > request_timeout_) Close(c);
  }
}

bool ConnectionWatch::StartStream() {
  std::lock_guard lock(mutex_);
  if (streams_ >= max_streams_) return false;
  ++streams_;
  return true;
}

void ConnectionWatch::StreamEnded() {
  std::lock_guard lock(mutex_);
  if (streams_ > 0) --streams_;
}

std::size_t ConnectionWatch::waiting() const {
  std::lock_guard lock(mutex_);
  std::size_t n = 0;
  for (const auto& [key, c] : connections_) n += c.waiting && !c.closing ? 1 : 0;
  return n;
}

}  // namespace mesocap::acquisition
