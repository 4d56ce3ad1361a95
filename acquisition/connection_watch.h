// What each connection of one control-server listener is doing, so that
// clients without a complete request cannot hold every slot: a connection
// waits (for its request's headers and body, or, kept alive, for its next
// request) at most `request_timeout`; when `max_waiting` already wait, a new
// connection closes the one that has waited longest; and at most
// `max_streams` event streams are open at once. libmicrohttpd's own idle
// timeout counts only the time since the last byte, so a client sending a
// byte now and then would otherwise keep its slot for ever.
//
// Connections are closed by shutdown(2) of their socket: the connection's
// own thread then sees the end and lets libmicrohttpd close it. A
// connection's entry goes (Closed) before libmicrohttpd closes its socket,
// so a socket number is never shut down after the system reused it.
#pragma once

#include <chrono>
#include <cstddef>
#include <map>
#include <mutex>

namespace mesocap::acquisition {

class ConnectionWatch {
 public:
  using Clock = std::chrono::steady_clock;

  ConnectionWatch(std::chrono::milliseconds request_timeout, std::size_t max_waiting, std::size_t max_streams)
      : request_timeout_(request_timeout), max_waiting_(max_waiting), max_streams_(max_streams) {}

  // A connection was accepted on socket `fd`: it waits for its request.
  void Opened(const void* connection, int fd);
  // Its request is complete: it is answered now.
  void Answering(const void* connection);
  // Its answer is sent; kept alive, it waits for its next request.
  void Answered(const void* connection);
  void Closed(const void* connection);
  // Shuts down every connection that has waited longer than the timeout.
  void CloseOverdue(Clock::time_point now);

  // An event stream may start (false when max_streams are open); each
  // started one ends with StreamEnded.
  bool StartStream();
  void StreamEnded();

  std::size_t waiting() const;

 private:
  struct Connection {
    int fd = -1;
    bool waiting = true;
    bool closing = false;  // shut down, not yet closed by libmicrohttpd
    Clock::time_point since;
  };
  void Close(Connection& c);  // under mutex_

  const std::chrono::milliseconds request_timeout_;
  const std::size_t max_waiting_, max_streams_;
  mutable std::mutex mutex_;
  std::map<const void*, Connection> connections_;
  std::size_t streams_ = 0;
};

}  // namespace mesocap::acquisition
