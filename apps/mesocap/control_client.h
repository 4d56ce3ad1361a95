// The `mesocap capture` commands' side of the capture daemon's control API
// (acquisition/control_api.h): HTTP over the daemon's Unix socket through
// libcurl.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

namespace mesocap {

class ControlClient {
 public:
  explicit ControlClient(std::filesystem::path socket);

  // The response's JSON body. Throws Error with the daemon's message when
  // it answers with an error status, and naming the socket when it cannot
  // be reached.
  nlohmann::json Get(const std::string& path) const;
  nlohmann::json Post(const std::string& path, const nlohmann::json& body) const;
  // Reads the server-sent events of GET `path`, calling `on_event(type,
  // data)` for each, until it returns false or the daemon ends the stream.
  void Stream(const std::string& path,
              const std::function<bool(std::string_view type, const nlohmann::json& data)>& on_event) const;

 private:
  nlohmann::json Request(const std::string& method, const std::string& path, const std::string* body) const;
  std::filesystem::path socket_;
};

// The socket a client uses without --socket: $MESOCAP_SOCKET, or the one
// the shipped unit file makes.
std::filesystem::path DefaultControlSocket();

}  // namespace mesocap
