// The control API (acquisition/control_api.h) served over HTTP on a Unix
// domain socket, and optionally on a loopback TCP port with a bearer token,
// by libmicrohttpd: one thread per connection, so an event stream may block
// waiting for the next event; a connection limit, an idle timeout and a
// request-body limit bound what hostile or slow clients cost.
//
// One libmicrohttpd daemon per listening socket: it takes one listening
// socket each, and the daemon a request arrives on says whether it needs
// the token, without reading the peer's address.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "acquisition/capture_daemon.h"
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
  unsigned connection_limit = 64;  // per listening socket
  std::chrono::seconds idle_timeout{15};

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
  };

 private:
  void ListenOnUnixSocket();
  void ListenOnLoopback();
  void Serve(Listener& listener, const std::string& name);

  CaptureDaemon& daemon_;
  ControlServerOptions options_;
  Listener unix_{this, false}, tcp_{this, true};
  std::uint16_t tcp_port_ = 0;
  bool socket_bound_ = false;  // the socket file is this server's to remove
  std::atomic<bool> stopping_{false};
};

}  // namespace mesocap::acquisition
