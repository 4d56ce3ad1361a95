// The control server's loopback TCP listener, through real sockets: a request
// without the bearer token gets 401 with a challenge, one with it gets the
// API's answer, the status page needs none; the listening socket is bound
// to 127.0.0.1 and nothing else (read from the kernel's socket table).
#include <gtest/gtest.h>
#include <ifaddrs.h>
#include <netinet/in.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "acquisition/control_server.h"
#include "acquisition/status_page.h"
#include "tests/acquisition/raw_http.h"
#include "tests/acquisition/served_daemon.h"

namespace mesocap::acquisition {
namespace {

using nlohmann::json;

const std::string& kTcpToken = kServedToken;

std::string Get(std::uint16_t port, const std::string& path, const std::string& extra_headers = "") {
  return SendRaw(ConnectTcp(port),
                 "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1\r\n" + extra_headers + "Connection: close\r\n\r\n");
}

// The local addresses of the sockets listening on `port` in /proc/net/`table`
// ("tcp" or "tcp6"), as the kernel writes them ("0100007F" is 127.0.0.1).
std::vector<std::string> ListeningAddresses(const std::string& table, std::uint16_t port) {
  std::ifstream in("/proc/self/net/" + table);
  std::string line;
  std::getline(in, line);  // the header
  char port_hex[8];
  std::snprintf(port_hex, sizeof port_hex, "%04X", port);
  std::vector<std::string> out;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string slot, local, remote, state;
    fields >> slot >> local >> remote >> state;
    const std::size_t colon = local.rfind(':');
    if (state == "0A" && colon != std::string::npos && local.substr(colon + 1) == port_hex) {
      out.push_back(local.substr(0, colon));
    }
  }
  return out;
}

using ControlServerTcpTest = ServedDaemonTest;

TEST_F(ControlServerTcpTest, ATokenGetsTheAnswerAndNoneOrAWrongOneGets401) {
  auto daemon = MakeDaemon();
  ControlServer server(*daemon, Options());
  const std::uint16_t port = server.tcp_port();
  ASSERT_NE(port, 0);

  std::string answer = Get(port, "/v1/rig");
  EXPECT_EQ(StatusOf(answer), 401) << answer;
  EXPECT_NE(answer.find("WWW-Authenticate: Bearer realm=\"mesocapd\"\r\n"), std::string::npos) << answer;
  EXPECT_NE(answer.find("Content-Type: application/json"), std::string::npos) << answer;
  EXPECT_EQ(json::parse(BodyOf(answer)).at("error"),
            "missing Authorization header: expected \"Authorization: Bearer TOKEN\" with the token in mesocapd's "
            "control.token");
  answer = Get(port, "/v1/rig", "Authorization: Bearer " + std::string(64, 'f') + "\r\n");
  EXPECT_EQ(StatusOf(answer), 401) << answer;
  EXPECT_EQ(json::parse(BodyOf(answer)).at("error"), "wrong bearer token: use the one in mesocapd's control.token");

  answer = Get(port, "/v1/rig", "Authorization: Bearer " + kTcpToken + "\r\n");
  ASSERT_EQ(StatusOf(answer), 200) << answer;
  EXPECT_EQ(json::parse(BodyOf(answer)).at("worker"), "idle");
  // A submit over TCP with the token makes a job; the same without does not.
  const std::string body = R"({"plan": "capture"})";
  const std::string submit = "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Length: " + std::to_string(body.size()) +
                             "\r\nConnection: close\r\n";
  EXPECT_EQ(StatusOf(SendRaw(ConnectTcp(port), submit + "\r\n" + body)), 401);
  EXPECT_TRUE(daemon->Jobs().empty());
  EXPECT_EQ(StatusOf(SendRaw(ConnectTcp(port), submit + "Authorization: Bearer " + kTcpToken + "\r\n\r\n" + body)),
            201);
  EXPECT_EQ(daemon->Jobs().size(), 1u);

  // The status page: without a token, its document only.
  answer = Get(port, "/");
  ASSERT_EQ(StatusOf(answer), 200) << answer.substr(0, 300);
  EXPECT_NE(answer.find("Content-Type: text/html; charset=utf-8\r\n"), std::string::npos);
  EXPECT_NE(answer.find("Content-Security-Policy: default-src 'none';"), std::string::npos);
  EXPECT_EQ(BodyOf(answer), std::string(StatusPageHtml()));
  EXPECT_EQ(StatusOf(Get(port, "/index.html")), 200);

  // The Unix socket needs no token.
  answer = SendRaw(state_ / "control.sock", "GET /v1/jobs HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(answer), 200) << answer;
}

TEST_F(ControlServerTcpTest, ItListensOn127001OnlyAndStopsListeningWhenStopped) {
  auto daemon = MakeDaemon();
  ControlServer server(*daemon, Options());
  const std::uint16_t port = server.tcp_port();
  char loopback[16];
  std::snprintf(loopback, sizeof loopback, "%08X", htonl(INADDR_LOOPBACK));
  EXPECT_EQ(ListeningAddresses("tcp", port), std::vector<std::string>{loopback});
  EXPECT_TRUE(ListeningAddresses("tcp6", port).empty());
  // Another address of this machine does not answer on the port.
  ifaddrs* addresses = nullptr;
  ASSERT_EQ(::getifaddrs(&addresses), 0);
  int others = 0;
  for (const ifaddrs* a = addresses; a != nullptr; a = a->ifa_next) {
    if (a->ifa_addr == nullptr || a->ifa_addr->sa_family != AF_INET) continue;
    char ip[INET_ADDRSTRLEN];
    ::inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(a->ifa_addr)->sin_addr, ip, sizeof ip);
    if (std::string(ip).rfind("127.", 0) == 0) continue;
    ++others;
    EXPECT_EQ(ConnectTcp(port, ip), -1) << ip << " answers on port " << port;
  }
  ::freeifaddrs(addresses);
  std::printf("checked %d non-loopback IPv4 addresses\n", others);
  // A second server cannot take the port; the message names it.
  ControlServerOptions second = Options();
  second.socket = state_ / "second.sock";
  second.tcp_port = port;
  try {
    ControlServer taken(*daemon, second);
    ADD_FAILURE() << "a second server listens on port " << port;
  } catch (const core::Error& e) {
    EXPECT_EQ(std::string(e.what()), "127.0.0.1:" + std::to_string(port) + ": cannot listen: Address already in use");
  }
  EXPECT_FALSE(fs::exists(state_ / "second.sock"));  // the failed server left nothing
  server.Stop();
  EXPECT_TRUE(ListeningAddresses("tcp", port).empty());
  EXPECT_EQ(ConnectTcp(port), -1);
}

TEST(ControlServerOptionsTest, ATcpPortNeedsABearerToken) {
  ControlServerOptions o;
  o.socket = "/tmp/x.sock";
  o.tcp_port = 0;
  EXPECT_EQ(o.Check(), "bearer_token must be a token (64 lowercase hex digits) when tcp_port is set");
  o.bearer_token = kTcpToken;
  EXPECT_EQ(o.Check(), "");
  o.tcp_port.reset();
  o.bearer_token.clear();
  EXPECT_EQ(o.Check(), "");
}

}  // namespace
}  // namespace mesocap::acquisition
