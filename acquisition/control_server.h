// The control API (acquisition/control_api.h) served over HTTP on a Unix
// domain socket, and optionally on a loopback TCP port with a bearer token,
// by libmicrohttpd: one thread per connection, so an event stream may block
// waiting for the next event; a connection limit, an idle timeout, a time
// limit on each request's arrival, a limit on event streams and a
// request-body limit bound what hostile or slow clients cost.
//
// One libmicrohttpd daemon per listening socket: it takes one listening
// socket each, and the daemon a request arrives on says whether it needs
// the token, without reading the peer's address.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "acquisition/capture_daemon.h"
#include "acquisition/connection_watch.h"
#include "core/error.h"

struct MHD_Daemon;

namespace mesocap::acquisition {

struct ControlServerOptions {
  std::filesystem::path socket;  // created (mode 0660); a stale one is replaced
  // When set, the API is served on 127.0.0.1 at this port too (0: a port
  // the kernel picks), never on another address.
  std::optional<std::uint16_t> tcp_port;
  // What a request over TCP must carry (acquisition/bearer_token.h);
  // required with tcp_port.
  std::string bearer_token;
  // Per listening socket: at most half of them wait for a request (a new
  // connection closes the one that waited longest) and a quarter are event
  // streams (acquisition/connection_watch.h).
  unsigned connection_limit = 64;
  std::chrono::seconds idle_timeout{15};
  // From a connection's accept (or its previous answer) to its complete
  // request; a connection still sending is closed after it.
  std::chrono::milliseconds request_timeout{5000};

  core::CheckResult Check() const;
};

class ControlServer {
 public:
  // Binds the socket (and the TCP port) and starts serving. Throws Error
  // naming the socket or the port when it cannot (another process listens
  // there, a path too long).
  ControlServer(CaptureDaemon& daemon, ControlServerOptions options);
  ~ControlServer();  // Stop()
  ControlServer(const ControlServer&) = delete;
  ControlServer& operator=(const ControlServer&) = delete;

  // Ends open event streams, stops serving and removes the socket.
  void Stop();

  // The TCP port it listens on (the one the kernel picked for port 0), or 0
  // without a TCP listener.
  std::uint16_t tcp_port() const { return tcp_port_; }

  // For the access handler.
  CaptureDaemon& daemon() { return daemon_; }
  const std::string& bearer_token() const { return options_.bearer_token; }
  bool stopping() const { return stopping_; }

  // One listening socket and the libmicrohttpd daemon serving it.
  struct Listener {
    ControlServer* server = nullptr;
    bool tcp = false;
    int fd = -1;  // until `http` takes it
    MHD_Daemon* http = nullptr;
    std::unique_ptr<ConnectionWatch> watch;
  };

 private:
  void ListenOnUnixSocket();
  void ListenOnLoopback();
  void Serve(Listener& listener, const std::string& name);
  // Closes the connections that waited too long for their request, a few
  // times a second, until Stop().
  void WatchConnections();

  CaptureDaemon& daemon_;
  ControlServerOptions options_;
  Listener unix_{this, false, -1, nullptr, nullptr}, tcp_{this, true, -1, nullptr, nullptr};
  std::uint16_t tcp_port_ = 0;
  bool socket_bound_ = false;  // the socket file is this server's to remove
  std::atomic<bool> stopping_{false};
  std::mutex watchdog_mutex_;
  std::condition_variable watchdog_wake_;
  std::thread watchdog_;
};

}  // namespace mesocap::acquisition
