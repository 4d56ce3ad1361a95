// The control server against clients that hold connections: trickling
// request headers on every listener do not lock out a client with the
// token, a request not complete in time is closed, event streams are
// limited per listener; what libmicrohttpd answers by itself (oversized
// headers) is what docs/DAEMON.md says; the socket is made without touching
// the process's umask.
#include <gtest/gtest.h>
#include <poll.h>

#include <atomic>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "tests/acquisition/raw_http.h"
#include "tests/acquisition/served_daemon.h"

namespace mesocap::acquisition {
namespace {

using nlohmann::json;

using ControlServerConnectionsTest = ServedDaemonTest;

// The start of a request whose headers never end, as a client that then
// sends a byte now and then.
int Trickling(int fd) {
  const std::string start = "GET /v1/rig HTTP/1.1\r\nHost: x\r\n";
  ::send(fd, start.data(), start.size(), MSG_NOSIGNAL);
  return fd;
}

// Sends a byte every 50 ms until the server closes the connection; false
// when it is still open after 60 s (a hang guard, not a measurement).
bool ClosedWhileTrickling(int fd) {
  for (int i = 0; i < 1200; ++i) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 50) > 0) {
      char byte;
      const ssize_t n = ::recv(fd, &byte, 1, MSG_DONTWAIT);
      if (n <= 0) return true;  // closed, with no answer
      return false;             // an answer to a request never sent in full
    }
    if (::send(fd, "X", 1, MSG_NOSIGNAL) < 0) return true;
  }
  return false;
}

// Sends `request` on `fd` and reads one whole answer (its headers and the
// Content-Length bytes after them, or the first bytes of a stream); the
// connection stays open.
std::string Answer(int fd, const std::string& request) {
  timeval timeout{20, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  ::send(fd, request.data(), request.size(), MSG_NOSIGNAL);
  std::string answer;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) {
    answer.append(buffer, static_cast<std::size_t>(n));
    const std::size_t end = answer.find("\r\n\r\n");
    if (end == std::string::npos) continue;
    const std::size_t length = answer.find("Content-Length: ");
    if (length == std::string::npos || length > end) break;  // a stream: its headers are enough
    if (answer.size() >= end + 4 + std::stoul(answer.substr(length + 16))) break;
  }
  return answer;
}

TEST_F(ControlServerConnectionsTest, TricklingConnectionsOnEveryListenerDoNotLockOutAClientWithTheToken) {
  auto daemon = MakeDaemon();
  const ControlServerOptions options = Options();
  ControlServer server(*daemon, options);
  std::vector<int> held;
  for (unsigned i = 0; i < options.connection_limit; ++i) {
    held.push_back(Trickling(ConnectTcp(server.tcp_port())));
    held.push_back(Trickling(ConnectUnix(options.socket)));
  }
  for (const int fd : held) ::send(fd, "X", 1, MSG_NOSIGNAL);
  const std::string tcp =
      SendRaw(ConnectTcp(server.tcp_port()), "GET /v1/rig HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " +
                                                 kServedToken + "\r\nConnection: close\r\n\r\n");
  ASSERT_EQ(StatusOf(tcp), 200) << tcp;
  EXPECT_EQ(json::parse(BodyOf(tcp)).at("worker"), "idle");
  const std::string unix = SendRaw(options.socket, "GET /v1/rig HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(unix), 200) << unix;
  for (const int fd : held) ::close(fd);
}

TEST_F(ControlServerConnectionsTest, ARequestNotCompleteInTimeIsClosedOnEveryListener) {
  auto daemon = MakeDaemon();
  ControlServerOptions options = Options();
  options.request_timeout = std::chrono::milliseconds(300);
  options.idle_timeout = std::chrono::seconds(600);  // only the request timeout can close it
  ControlServer server(*daemon, options);
  EXPECT_TRUE(ClosedWhileTrickling(Trickling(ConnectTcp(server.tcp_port()))));
  EXPECT_TRUE(ClosedWhileTrickling(Trickling(ConnectUnix(options.socket))));
  // A request line of binary bytes that never ends: closed without an answer.
  const int binary = ConnectUnix(options.socket);
  ::send(binary, "\x16\x03\x01\x02\x00\x01\x00\x01\xfc\x03\x03", 11, MSG_NOSIGNAL);
  EXPECT_TRUE(ClosedWhileTrickling(binary));
  ::close(binary);
  // A kept-alive connection waiting for its next request counts the same.
  const int kept = ConnectUnix(options.socket);
  ASSERT_EQ(StatusOf(Answer(kept, "GET /v1/rig HTTP/1.1\r\nHost: x\r\n\r\n")), 200);
  EXPECT_TRUE(ClosedWhileTrickling(Trickling(kept)));
  ::close(kept);
}

TEST_F(ControlServerConnectionsTest, EventStreamsTakeAQuarterOfTheSlotsOfEachListener) {
  auto daemon = MakeDaemon();
  const ControlServerOptions options = Options();
  ControlServer server(*daemon, options);
  std::vector<int> streams;
  for (unsigned i = 0; i < options.connection_limit / 4; ++i) {
    const int fd = ConnectUnix(options.socket);
    ASSERT_EQ(StatusOf(Answer(fd, "GET /v1/events HTTP/1.1\r\nHost: x\r\n\r\n")), 200) << i;
    streams.push_back(fd);
  }
  const int extra = ConnectUnix(options.socket);
  const std::string refused = Answer(extra, "GET /v1/events HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  ::close(extra);
  EXPECT_EQ(StatusOf(refused), 429) << refused;
  EXPECT_EQ(json::parse(BodyOf(refused)).at("error"),
            "GET /v1/events: too many event streams open on this socket; close one, or poll GET /v1/jobs");
  // The other listener has its own, and other requests are answered.
  const int tcp = ConnectTcp(server.tcp_port());
  const std::string stream =
      Answer(tcp, "GET /v1/events HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kServedToken + "\r\n\r\n");
  EXPECT_EQ(StatusOf(stream), 200) << stream;
  ::close(tcp);
  const std::string rig = SendRaw(options.socket, "GET /v1/rig HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(rig), 200) << rig;
  for (const int fd : streams) ::close(fd);
}

// Documented exceptions to "every answer is JSON": libmicrohttpd answers
// these itself, before the API sees the request.
TEST_F(ControlServerConnectionsTest, WhatTheHttpLibraryAnswersByItselfIsWhatTheDocumentSays) {
  auto daemon = MakeDaemon();
  const ControlServerOptions options = Options();
  ControlServer server(*daemon, options);
  const std::string headers =
      SendRaw(options.socket, "GET /v1/rig HTTP/1.1\r\nHost: x\r\nX: " + std::string(100000, 'h') + "\r\n\r\n");
  EXPECT_EQ(StatusOf(headers), 431) << headers.substr(0, 300);
  const std::string line = SendRaw(options.socket, "GET /" + std::string(100000, 'u') + " HTTP/1.1\r\n\r\n");
  EXPECT_EQ(StatusOf(line), 414) << line.substr(0, 300);
  const std::string malformed = SendRaw(options.socket, "NOT HTTP AT ALL\r\n\r\n");
  EXPECT_EQ(StatusOf(malformed), 400) << malformed;
  const std::string version = SendRaw(options.socket, "GET / HTTP/2.0\r\nHost: x\r\n\r\n");
  EXPECT_EQ(StatusOf(version), 505) << version;
  // Binary bytes up to a line break: closed without an answer.
  EXPECT_EQ(SendRaw(options.socket, std::string("\x16\x03\x01\x02\x00\x01\xfc\x03\x03\r\n\r\n", 13)), "");
  // The API's own answer to what libmicrohttpd passes on is JSON.
  const std::string unknown = SendRaw(options.socket, "BREW /v1/rig HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(unknown), 405) << unknown;
  EXPECT_EQ(json::parse(BodyOf(unknown)).at("error"), "BREW /v1/rig: method not allowed (use GET)");
}

// The umask as the kernel reports it (reading it with umask(2) would set it).
std::string Umask() {
  std::ifstream in("/proc/self/status");
  for (std::string row; std::getline(in, row);) {
    if (row.rfind("Umask:", 0) == 0) return row;
  }
  return "";
}

TEST_F(ControlServerConnectionsTest, TheSocketIs0660AndTheProcessUmaskIsNeverChanged) {
  auto daemon = MakeDaemon();
  ControlServerOptions options = Options();
  options.tcp_port.reset();
  const std::string umask = Umask();
  ASSERT_FALSE(umask.empty());
  std::atomic<bool> done{false};
  std::atomic<int> changed{0};
  std::thread watcher([&] {
    while (!done) changed += Umask() != umask ? 1 : 0;
  });
  for (int i = 0; i < 200; ++i) {
    ControlServer server(*daemon, options);
    EXPECT_EQ(fs::status(options.socket).permissions() & fs::perms::all, fs::perms(0660));
  }
  done = true;
  watcher.join();
  EXPECT_EQ(changed, 0) << "another thread saw the umask changed";
}

}  // namespace
}  // namespace mesocap::acquisition
