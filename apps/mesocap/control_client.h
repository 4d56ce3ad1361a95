// The `mesocap capture` commands' side of the capture daemon's control API
// (acquisition/control_api.h): HTTP through libcurl over the daemon's Unix
// socket, or over its loopback TCP port with the bearer token.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace mesocap {

// Where mesocapd listens: its Unix socket, or its loopback TCP address with
// the bearer token.
struct ControlEndpoint {
  std::filesystem::path socket;
  std::string url;    // "http://127.0.0.1:PORT" instead of the socket
  std::string token;  // with url

  std::string Name() const { return url.empty() ? socket.string() : url; }
};

// The endpoint of `mesocap capture --url URL --token-file FILE`. Throws
// Error naming the flag when the URL is not mesocapd's loopback form
// (http://127.0.0.1:PORT) or the file holds no token.
ControlEndpoint LoopbackControlEndpoint(const std::string& url, const std::filesystem::path& token_file);

class ControlClient {
 public:
  explicit ControlClient(ControlEndpoint endpoint);

  // The response's JSON body. Throws Error with the daemon's message when
  // it answers with an error status, and naming the socket when it cannot
  // be reached.
  nlohmann::json Get(const std::string& path) const;
  nlohmann::json Post(const std::string& path, const nlohmann::json& body) const;
  nlohmann::json Delete(const std::string& path) const;
  // Reads the server-sent events of GET `path`, calling `on_event(type,
  // data)` for each, until it returns false or the daemon ends the stream.
  void Stream(const std::string& path,
              const std::function<bool(std::string_view type, const nlohmann::json& data)>& on_event) const;

 private:
  nlohmann::json Request(const std::string& method, const std::string& path, const std::string* body) const;
  ControlEndpoint endpoint_;
};

// The socket the shipped unit file makes.
inline constexpr const char* kShippedControlSocket = "/var/lib/mesocapd/control.sock";

// The socket a client uses without --socket: $MESOCAP_SOCKET, or the
// shipped one.
std::filesystem::path DefaultControlSocket();

}  // namespace mesocap
