#include "apps/mesocap/control_client.h"

#include <curl/curl.h>

#include <cstdlib>
#include <memory>

#include "core/error.h"

namespace mesocap {
namespace {

using nlohmann::json;

std::size_t Append(char* data, std::size_t size, std::size_t count, void* out) {
  static_cast<std::string*>(out)->append(data, size * count);
  return size * count;
}

struct CurlDeleter {
  void operator()(CURL* curl) const { curl_easy_cleanup(curl); }
};
struct HeaderListDeleter {
  void operator()(curl_slist* list) const { curl_slist_free_all(list); }
};
using Curl = std::unique_ptr<CURL, CurlDeleter>;

Curl Open(const std::filesystem::path& socket, const std::string& path) {
  Curl curl(curl_easy_init());
  if (!curl) throw core::Error("libcurl: cannot start a request");
  curl_easy_setopt(curl.get(), CURLOPT_UNIX_SOCKET_PATH, socket.c_str());
  // The host name is a placeholder: the socket is the address.
  const std::string url = "http://mesocapd" + path;
  curl_easy_setopt(curl.get(), CURLOPT_URL, url.c_str());
  curl_easy_setopt(curl.get(), CURLOPT_NOSIGNAL, 1L);
  return curl;
}

std::string Unreachable(const std::filesystem::path& socket, CURLcode code) {
  return "cannot reach mesocapd at " + socket.string() + ": " + curl_easy_strerror(code) +
         " (is it running? --socket or MESOCAP_SOCKET names its socket)";
}

// SSE framing (WHATWG HTML "server-sent events"): lines "event: T" and
// "data: D", a blank line ends a message, lines from ':' are comments.
struct EventParser {
  std::string buffer, type, data;
  const std::function<bool(std::string_view, const json&)>* on_event = nullptr;
  bool stopped = false;

  bool Feed(std::string_view bytes) {
    buffer.append(bytes);
    std::size_t start = 0;
    for (std::size_t end; (end = buffer.find('\n', start)) != std::string::npos; start = end + 1) {
      const std::string_view line(buffer.data() + start, end - start);
      if (line.empty()) {
        if (!data.empty()) {
          const json parsed = json::parse(data, nullptr, false);
          if (!parsed.is_discarded() && !(*on_event)(type.empty() ? "message" : type, parsed)) {
            stopped = true;
            return false;
          }
        }
        type.clear();
        data.clear();
      } else if (line.substr(0, 7) == "event: ") {
        type = line.substr(7);
      } else if (line.substr(0, 6) == "data: ") {
        data += line.substr(6);
      }
    }
    buffer.erase(0, start);
    return true;
  }
};

std::size_t FeedEvents(char* data, std::size_t size, std::size_t count, void* parser) {
  return static_cast<EventParser*>(parser)->Feed({data, size * count}) ? size * count : 0;
}

}  // namespace

std::filesystem::path DefaultControlSocket() {
  if (const char* env = std::getenv("MESOCAP_SOCKET"); env != nullptr && *env != '\0') return env;
  return "/var/lib/mesocapd/control.sock";
}

ControlClient::ControlClient(std::filesystem::path socket) : socket_(std::move(socket)) {}

json ControlClient::Get(const std::string& path) const { return Request("GET", path, nullptr); }

json ControlClient::Post(const std::string& path, const json& body) const {
  const std::string text = body.dump();
  return Request("POST", path, &text);
}

json ControlClient::Request(const std::string& method, const std::string& path, const std::string* body) const {
  Curl curl = Open(socket_, path);
  std::string response;
  curl_easy_setopt(curl.get(), CURLOPT_WRITEFUNCTION, Append);
  curl_easy_setopt(curl.get(), CURLOPT_WRITEDATA, &response);
  curl_easy_setopt(curl.get(), CURLOPT_TIMEOUT, 30L);
  std::unique_ptr<curl_slist, HeaderListDeleter> headers;
  if (method == "POST") {
    headers.reset(curl_slist_append(nullptr, "Content-Type: application/json"));
    curl_easy_setopt(curl.get(), CURLOPT_HTTPHEADER, headers.get());
    curl_easy_setopt(curl.get(), CURLOPT_POSTFIELDS, body->c_str());
    curl_easy_setopt(curl.get(), CURLOPT_POSTFIELDSIZE, static_cast<long>(body->size()));
  }
  if (const CURLcode code = curl_easy_perform(curl.get()); code != CURLE_OK) {
    throw core::Error(Unreachable(socket_, code));
  }
  long status = 0;
  curl_easy_getinfo(curl.get(), CURLINFO_RESPONSE_CODE, &status);
  const json parsed = json::parse(response, nullptr, false);
  if (parsed.is_discarded()) {
    throw core::Error("mesocapd at " + socket_.string() + ": " + method + " " + path + " answered " +
                      std::to_string(status) + " with a body that is not JSON");
  }
  if (status >= 400) {
    throw core::Error("mesocapd: " + (parsed.contains("error") && parsed["error"].is_string()
                                          ? parsed["error"].get<std::string>()
                                          : "status " + std::to_string(status)));
  }
  return parsed;
}

void ControlClient::Stream(const std::string& path,
                           const std::function<bool(std::string_view, const json&)>& on_event) const {
  Curl curl = Open(socket_, path);
  EventParser parser;
  parser.on_event = &on_event;
  curl_easy_setopt(curl.get(), CURLOPT_WRITEFUNCTION, FeedEvents);
  curl_easy_setopt(curl.get(), CURLOPT_WRITEDATA, &parser);
  const CURLcode code = curl_easy_perform(curl.get());
  if (parser.stopped) return;
  if (code != CURLE_OK) throw core::Error(Unreachable(socket_, code));
}

}  // namespace mesocap
