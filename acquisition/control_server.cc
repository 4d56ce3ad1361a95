#include "acquisition/control_server.h"

#include <arpa/inet.h>
#include <microhttpd.h>
#include <netinet/in.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <memory>
#include <nlohmann/json.hpp>

#include "acquisition/bearer_token.h"
#include "acquisition/control_api.h"
#include "core/error.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;

// One request as it arrives: libmicrohttpd calls the access handler first
// with the headers, then with each piece of the body, then once more.
struct PendingRequest {
  ControlRequest request;
};

// An event stream's state between the reader's calls.
struct EventStream {
  ControlServer* server = nullptr;
  ConnectionWatch* watch = nullptr;  // counts the open streams
  std::uint64_t after = 0;
  std::string pending;  // bytes of messages not yet handed to libmicrohttpd

  explicit EventStream(ControlServer* s, ConnectionWatch* w, std::uint64_t a) : server(s), watch(w), after(a) {}
  ~EventStream() { watch->StreamEnded(); }
  EventStream(const EventStream&) = delete;
  EventStream& operator=(const EventStream&) = delete;
};

ssize_t ReadEvents(void* cls, std::uint64_t, char* buffer, std::size_t max) {
  auto* stream = static_cast<EventStream*>(cls);
  while (stream->pending.empty()) {
    if (stream->server->stopping()) return MHD_CONTENT_READER_END_OF_STREAM;
    const std::vector<DaemonEvent> events =
        stream->server->daemon().events().After(stream->after, std::chrono::milliseconds(1000));
    if (stream->server->daemon().events().closed()) return MHD_CONTENT_READER_END_OF_STREAM;
    for (const DaemonEvent& e : events) {
      stream->pending += EventStreamMessage(e);
      stream->after = e.number;
    }
    // A comment line keeps an idle stream inside the idle timeout.
    if (events.empty()) stream->pending = ": waiting\n\n";
  }
  const std::size_t n = std::min(max, stream->pending.size());
  std::memcpy(buffer, stream->pending.data(), n);
  stream->pending.erase(0, n);
  return static_cast<ssize_t>(n);
}

void FreeEventStream(void* cls) { delete static_cast<EventStream*>(cls); }

MHD_Result Respond(MHD_Connection* connection, const ControlResponse& r) {
  MHD_Response* response =
      MHD_create_response_from_buffer(r.body.size(), const_cast<char*>(r.body.data()), MHD_RESPMEM_MUST_COPY);
  if (response == nullptr) return MHD_NO;
  MHD_add_response_header(response, "Content-Type", r.content_type.c_str());
  MHD_add_response_header(response, "Cache-Control", "no-store");
  for (const auto& [name, value] : r.headers) MHD_add_response_header(response, name.c_str(), value.c_str());
  const MHD_Result result = MHD_queue_response(connection, static_cast<unsigned>(r.status), response);
  MHD_destroy_response(response);
  return result;
}

MHD_Result AddQueryArgument(void* cls, MHD_ValueKind, const char* key, const char* value) {
  auto* query = static_cast<std::string*>(cls);
  if (!query->empty()) *query += '&';
  *query += key;
  if (value != nullptr) *query += std::string("=") + value;
  return MHD_YES;
}

// An event stream, or 429 when the listener has its most open already.
MHD_Result StartEventStream(const ControlServer::Listener& listener, MHD_Connection* connection, std::uint64_t after) {
  if (!listener.watch->StartStream()) {
    ControlResponse refused;
    refused.status = 429;
    refused.body = nlohmann::json{{"error", "GET /v1/events: too many event streams open on this " +
                                                std::string(listener.tcp ? "port" : "socket") +
                                                "; close one, or poll GET /v1/jobs"}}
                       .dump() +
                   "\n";
    return Respond(connection, refused);
  }
  auto stream = std::make_unique<EventStream>(listener.server, listener.watch.get(), after);
  MHD_Response* r =
      MHD_create_response_from_callback(MHD_SIZE_UNKNOWN, 4096, ReadEvents, stream.get(), FreeEventStream);
  if (r == nullptr) return MHD_NO;
  stream.release();
  MHD_add_response_header(r, "Content-Type", "text/event-stream");
  MHD_add_response_header(r, "Cache-Control", "no-store");
  const MHD_Result result = MHD_queue_response(connection, MHD_HTTP_OK, r);
  MHD_destroy_response(r);
  return result;
}

MHD_Result HandleConnection(void* cls, MHD_Connection* connection, const char* url, const char* method, const char*,
                            const char* upload_data, std::size_t* upload_data_size, void** con_cls) {
  const auto* listener = static_cast<ControlServer::Listener*>(cls);
  ControlServer* server = listener->server;
  const auto answer = [&](const ControlResponse& r) {
    listener->watch->Answering(connection);
    return Respond(connection, r);
  };
  auto* pending = static_cast<PendingRequest*>(*con_cls);
  if (pending == nullptr) {
    pending = new PendingRequest;
    *con_cls = pending;
    ControlRequest& request = pending->request;
    request.method = method;
    request.path = url;
    MHD_get_connection_values(connection, MHD_GET_ARGUMENT_KIND, AddQueryArgument, &request.query);
    request.over_tcp = listener->tcp;
    if (const char* value = MHD_lookup_connection_value(connection, MHD_HEADER_KIND, "Authorization")) {
      request.authorization = value;
    }
    // A request without the right token is refused before its body is read.
    if (auto refused = RefusedAccess(request, server->bearer_token())) return answer(*refused);
    // So is a declared body over the limit.
    if (const char* length = MHD_lookup_connection_value(connection, MHD_HEADER_KIND, "Content-Length")) {
      char* end = nullptr;
      errno = 0;
      const unsigned long long declared = std::strtoull(length, &end, 10);
      if (errno != 0 || end == length || declared > kMaxRequestBodyBytes) {
        request.body_too_large = true;
        return answer(HandleControlRequest(server->daemon(), request, server->bearer_token()));
      }
    }
    return MHD_YES;
  }
  if (*upload_data_size > 0) {
    // A chunked body over the limit is read and dropped, never held.
    if (pending->request.body.size() + *upload_data_size > kMaxRequestBodyBytes) {
      pending->request.body_too_large = true;
      pending->request.body.clear();
    } else if (!pending->request.body_too_large) {
      pending->request.body.append(upload_data, *upload_data_size);
    }
    *upload_data_size = 0;
    return MHD_YES;
  }
  const ControlResponse response = HandleControlRequest(server->daemon(), pending->request, server->bearer_token());
  if (!response.event_stream) return answer(response);
  listener->watch->Answering(connection);
  return StartEventStream(*listener, connection, response.events_after);
}

void RequestCompleted(void* cls, MHD_Connection* connection, void** con_cls, MHD_RequestTerminationCode) {
  delete static_cast<PendingRequest*>(*con_cls);
  *con_cls = nullptr;
  static_cast<ControlServer::Listener*>(cls)->watch->Answered(connection);
}

void ConnectionChanged(void* cls, MHD_Connection* connection, void**, MHD_ConnectionNotificationCode code) {
  ConnectionWatch& watch = *static_cast<ControlServer::Listener*>(cls)->watch;
  if (code == MHD_CONNECTION_NOTIFY_STARTED) {
    const MHD_ConnectionInfo* info = MHD_get_connection_info(connection, MHD_CONNECTION_INFO_CONNECTION_FD);
    if (info != nullptr) watch.Opened(connection, info->connect_fd);
  } else {
    watch.Closed(connection);
  }
}

void LogServerError(void*, const char* format, va_list args) {
  char text[512];
  std::vsnprintf(text, sizeof text, format, args);
  spdlog::debug("http: {}", text);
}

}  // namespace

core::CheckResult ControlServerOptions::Check() const {
  if (socket.empty()) return "socket must name the control socket's path";
  if (socket.native().size() >= sizeof(sockaddr_un::sun_path)) {
    return "socket " + socket.string() + ": longer than " + std::to_string(sizeof(sockaddr_un::sun_path) - 1) +
           " bytes, the most a Unix socket's path may have";
  }
  if (tcp_port && !IsBearerToken(bearer_token)) {
    return "bearer_token must be a token (" + std::to_string(kBearerTokenHexDigits) +
           " lowercase hex digits) when tcp_port is set";
  }
  if (connection_limit < 4) return "connection_limit must be at least 4";
  if (idle_timeout.count() < 1) return "idle_timeout must be at least 1 s";
  if (request_timeout.count() < 100) return "request_timeout must be at least 100 ms";
  return {};
}

void ControlServer::Serve(Listener& listener, const std::string& name) {
  listener.watch = std::make_unique<ConnectionWatch>(options_.request_timeout, options_.connection_limit / 2,
                                                     options_.connection_limit / 4);
  listener.http = MHD_start_daemon(
      MHD_USE_THREAD_PER_CONNECTION | MHD_USE_INTERNAL_POLLING_THREAD | MHD_USE_POLL | MHD_USE_ERROR_LOG, 0, nullptr,
      nullptr, &HandleConnection, &listener, MHD_OPTION_LISTEN_SOCKET, listener.fd, MHD_OPTION_CONNECTION_LIMIT,
      options_.connection_limit, MHD_OPTION_CONNECTION_TIMEOUT, static_cast<unsigned>(options_.idle_timeout.count()),
      MHD_OPTION_CONNECTION_MEMORY_LIMIT, static_cast<std::size_t>(32 * 1024), MHD_OPTION_NOTIFY_COMPLETED,
      &RequestCompleted, &listener, MHD_OPTION_NOTIFY_CONNECTION, &ConnectionChanged, &listener,
      MHD_OPTION_EXTERNAL_LOGGER, &LogServerError, nullptr, MHD_OPTION_END);
  if (listener.http == nullptr) throw core::Error(name + ": the HTTP server did not start");
  listener.fd = -1;  // MHD_stop_daemon closes it
}

ControlServer::ControlServer(CaptureDaemon& daemon, ControlServerOptions options)
    : daemon_(daemon), options_(std::move(options)) {
  core::ThrowIfInvalid(options_.Check(), "control server");
  ListenOnUnixSocket();
  try {
    Serve(unix_, options_.socket.string());
    if (options_.tcp_port) {
      ListenOnLoopback();
      Serve(tcp_, "127.0.0.1:" + std::to_string(tcp_port_));
    }
    watchdog_ = std::thread([this] { WatchConnections(); });
  } catch (...) {
    Stop();
    throw;
  }
}

void ControlServer::ListenOnUnixSocket() {
  const std::string path = options_.socket.string();
  int& fd = unix_.fd;
  fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw core::Error(path + ": cannot make a socket: " + std::strerror(errno));
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  // A socket file left by a killed daemon is stale when nobody answers on it.
  if (fs::is_socket(fs::symlink_status(options_.socket))) {
    const int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const bool answered = ::connect(probe, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
    ::close(probe);
    if (answered) {
      ::close(fd);
      fd = -1;
      throw core::Error(path + ": another daemon listens on this socket");
    }
    fs::remove(options_.socket);
  }
  // Bound, then chmod-ed, then listening: nobody can connect before the
  // mode is 0660 (connect is refused until listen), and the process's umask,
  // which every thread shares, is left alone.
  const bool bound = ::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0;
  const bool ready = bound && ::chmod(path.c_str(), 0660) == 0 && ::listen(fd, 64) == 0;
  if (!ready) {
    const int e = errno;
    ::close(fd);
    fd = -1;
    if (bound) fs::remove(options_.socket);
    throw core::Error(path + ": cannot listen: " + std::strerror(e));
  }
  socket_bound_ = true;
}

void ControlServer::ListenOnLoopback() {
  const std::string name = "127.0.0.1:" + std::to_string(*options_.tcp_port);
  int& fd = tcp_.fd;
  fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) throw core::Error(name + ": cannot make a socket: " + std::strerror(errno));
  // A restarted daemon takes its port back while old connections linger.
  const int one = 1;
  ::setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(*options_.tcp_port);
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);  // never another address
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0 || ::listen(fd, 64) != 0) {
    const int e = errno;
    ::close(fd);
    fd = -1;
    throw core::Error(name + ": cannot listen: " + std::strerror(e));
  }
  socklen_t size = sizeof address;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size);
  tcp_port_ = ntohs(address.sin_port);
}

void ControlServer::WatchConnections() {
  std::unique_lock lock(watchdog_mutex_);
  while (!stopping_) {
    for (Listener* listener : {&unix_, &tcp_}) {
      if (listener->watch) listener->watch->CloseOverdue(ConnectionWatch::Clock::now());
    }
    watchdog_wake_.wait_for(lock, std::chrono::milliseconds(100));
  }
}

ControlServer::~ControlServer() { Stop(); }

void ControlServer::Stop() {
  {
    std::lock_guard lock(watchdog_mutex_);
    stopping_ = true;
  }
  watchdog_wake_.notify_all();
  if (watchdog_.joinable()) watchdog_.join();
  // Joins every connection's thread (event streams end within a second) and
  // closes the listening socket; one it never took is closed here.
  for (Listener* listener : {&unix_, &tcp_}) {
    if (listener->http != nullptr) MHD_stop_daemon(listener->http);
    listener->http = nullptr;
    if (listener->fd >= 0) ::close(listener->fd);
    listener->fd = -1;
  }
  if (socket_bound_) {
    std::error_code ec;
    fs::remove(options_.socket, ec);
    socket_bound_ = false;
  }
}

}  // namespace mesocap::acquisition
