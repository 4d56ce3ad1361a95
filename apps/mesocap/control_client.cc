#include "apps/mesocap/control_client.h"

#include <curl/curl.h>

#include <charconv>
#include <cstdlib>
#include <memory>

#include "acquisition/bearer_token.h"
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

// One request: the handle and the header list it points to.
struct Curl {
  std::unique_ptr<CURL, CurlDeleter> handle;
  std::unique_ptr<curl_slist, HeaderListDeleter> headers;
  CURL* get() const { return handle.get(); }
  void AddHeader(const std::string& header) {
    curl_slist* list = curl_slist_append(headers.get(), header.c_str());
    if (list == nullptr) throw core::Error("libcurl: cannot add a header");
    headers.release();
    headers.reset(list);
    curl_easy_setopt(handle.get(), CURLOPT_HTTPHEADER, list);
  }
};

Curl Open(const ControlEndpoint& endpoint, const std::string& path) {
  Curl curl{std::unique_ptr<CURL, CurlDeleter>(curl_easy_init()), nullptr};
  if (!curl.handle) throw core::Error("libcurl: cannot start a request");
  std::string url;
  if (endpoint.url.empty()) {
    curl_easy_setopt(curl.get(), CURLOPT_UNIX_SOCKET_PATH, endpoint.socket.c_str());
    // The host name is a placeholder: the socket is the address.
    url = "http://mesocapd" + path;
  } else {
    url = endpoint.url + path;
    curl.AddHeader("Authorization: Bearer " + endpoint.token);
    // Never through a proxy ($http_proxy), which would see the token.
    curl_easy_setopt(curl.get(), CURLOPT_NOPROXY, "*");
  }
  curl_easy_setopt(curl.get(), CURLOPT_URL, url.c_str());
  curl_easy_setopt(curl.get(), CURLOPT_NOSIGNAL, 1L);
  return curl;
}

std::string Unreachable(const ControlEndpoint& endpoint, CURLcode code) {
  if (code == CURLE_GOT_NOTHING) {
    return "mesocapd at " + endpoint.Name() +
           " closed the connection without an answer: it was at its connection limit (it closes requests not "
           "complete a few seconds after they connect, and the oldest unfinished one when every slot is taken); "
           "try again";
  }
  return "cannot reach mesocapd at " + endpoint.Name() + ": " + curl_easy_strerror(code) +
         (endpoint.url.empty() ? " (is it running? --socket or MESOCAP_SOCKET names its socket)"
                               : " (is it running with --tcp-port? its port is in STATE/control.port)");
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
  return kShippedControlSocket;
}

ControlEndpoint LoopbackControlEndpoint(const std::string& url, const std::filesystem::path& token_file) {
  constexpr std::string_view kPrefix = "http://127.0.0.1:";
  std::string_view port = url;
  bool valid = port.substr(0, kPrefix.size()) == kPrefix;
  port.remove_prefix(valid ? kPrefix.size() : 0);
  if (!port.empty() && port.back() == '/') port.remove_suffix(1);
  unsigned number = 0;
  const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), number);
  valid = valid && ec == std::errc() && end == port.data() + port.size() && number >= 1 && number <= 65535;
  if (!valid) {
    throw core::Error(
        "--url: expected http://127.0.0.1:PORT (mesocapd listens on loopback only; its port is in "
        "STATE/control.port), got " +
        core::Quoted(url));
  }
  ControlEndpoint endpoint;
  endpoint.url = std::string(kPrefix) + std::to_string(number);
  try {
    endpoint.token = acquisition::ReadBearerTokenFile(token_file);
  } catch (const core::Error& e) {
    throw core::Error(std::string("--token-file: ") + e.what());
  }
  return endpoint;
}

ControlClient::ControlClient(ControlEndpoint endpoint) : endpoint_(std::move(endpoint)) {}

json ControlClient::Get(const std::string& path) const { return Request("GET", path, nullptr); }

json ControlClient::Post(const std::string& path, const json& body) const {
  const std::string text = body.dump();
  return Request("POST", path, &text);
}

json ControlClient::Delete(const std::string& path) const { return Request("DELETE", path, nullptr); }

json ControlClient::Request(const std::string& method, const std::string& path, const std::string* body) const {
  Curl curl = Open(endpoint_, path);
  std::string response;
  curl_easy_setopt(curl.get(), CURLOPT_WRITEFUNCTION, Append);
  curl_easy_setopt(curl.get(), CURLOPT_WRITEDATA, &response);
  curl_easy_setopt(curl.get(), CURLOPT_TIMEOUT, 30L);
  if (method == "POST") {
    curl.AddHeader("Content-Type: application/json");
    curl_easy_setopt(curl.get(), CURLOPT_POSTFIELDS, body->c_str());
    curl_easy_setopt(curl.get(), CURLOPT_POSTFIELDSIZE, static_cast<long>(body->size()));
  } else if (method != "GET") {
    curl_easy_setopt(curl.get(), CURLOPT_CUSTOMREQUEST, method.c_str());
  }
  if (const CURLcode code = curl_easy_perform(curl.get()); code != CURLE_OK) {
    throw core::Error(Unreachable(endpoint_, code));
  }
  long status = 0;
  curl_easy_getinfo(curl.get(), CURLINFO_RESPONSE_CODE, &status);
  const json parsed = json::parse(response, nullptr, false);
  if (parsed.is_discarded()) {
    throw core::Error("mesocapd at " + endpoint_.Name() + ": " + method + " " + path + " answered " +
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
  Curl curl = Open(endpoint_, path);
  EventParser parser;
  parser.on_event = &on_event;
  curl_easy_setopt(curl.get(), CURLOPT_WRITEFUNCTION, FeedEvents);
  curl_easy_setopt(curl.get(), CURLOPT_WRITEDATA, &parser);
  const CURLcode code = curl_easy_perform(curl.get());
  if (parser.stopped) return;
  if (code != CURLE_OK) throw core::Error(Unreachable(endpoint_, code));
}

}  // namespace mesocap
