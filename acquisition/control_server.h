// The control API (acquisition/control_api.h) served over HTTP on a Unix
// domain socket, by libmicrohttpd: one thread per connection, so an event
// stream may block waiting for the next event; a connection limit, an idle
// timeout and a request-body limit bound what hostile or slow clients cost.
#pragma once

#include <atomic>
#include <chrono>
#include <filesystem>
#include <string>

#include "acquisition/capture_daemon.h"

struct MHD_Daemon;

namespace mesocap::acquisition {

struct ControlServerOptions {
  std::filesystem::path socket;  // created (mode 0660); a stale one is replaced
  unsigned connection_limit = 64;
  std::chrono::seconds idle_timeout{15};

  std::string Check() const;
};

class ControlServer {
 public:
  // Binds the socket and starts serving. Throws Error naming the socket
  // when it cannot (another process listens there, a path too long).
  ControlServer(CaptureDaemon& daemon, ControlServerOptions options);
  ~ControlServer();  // Stop()
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  // Ends open event streams, stops serving and removes the socket.
  void Stop();

  // For the access handler.
  CaptureDaemon& daemon() { return daemon_; }
  bool stopping() const { return stopping_; }

 private:
  CaptureDaemon& daemon_;
  ControlServerOptions options_;
  int listen_fd_ = -1;
  MHD_Daemon* http_ = nullptr;
  std::atomic<bool> stopping_{false};
};

}  // namespace mesocap::acquisition
