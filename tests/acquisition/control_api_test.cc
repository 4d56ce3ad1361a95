// The control API: each endpoint against the daemon's state, and 10 000
// malformed or hostile requests while a capture runs (9000 to the route
// table, 1000 raw through the socket): each gets a 4xx JSON error naming
// what is wrong, or its connection is closed; the daemon stays up, and the
// capture ends with the session an undisturbed run records. 9000 more with
// the rig idle show the daemon's memory stays bounded.
#include "acquisition/control_api.h"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <fstream>
#include <random>

#include "acquisition/control_server.h"
#include "tests/acquisition/simulated_daemon.h"

namespace mesocap::acquisition {
namespace {

using nlohmann::json;

ControlResponse Call(CaptureDaemon& daemon, const std::string& method, const std::string& path,
                     const std::string& body = "", const std::string& query = "") {
  return HandleControlRequest(daemon, {method, path, query, body, false});
}

std::string ErrorOf(const ControlResponse& r) {
  const json body = json::parse(r.body, nullptr, false);
  return body.is_object() && body.contains("error") ? body["error"].get<std::string>() : "(no error member)";
}

TEST_F(SimulatedDaemonTest, EndpointsAnswerWithTheDaemonsState) {
  auto daemon = MakeDaemon();
  ControlResponse r = Call(*daemon, "POST", "/v1/jobs", R"({"plan": "capture"})");
  ASSERT_EQ(r.status, 201) << r.body;
  const std::string id = json::parse(r.body).at("id");
  EXPECT_EQ(id, "job-000001");
  r = Call(*daemon, "GET", "/v1/jobs");
  EXPECT_EQ(json::parse(r.body).at("jobs").size(), 1u);
  r = Call(*daemon, "POST", "/v1/jobs/" + id + "/pause");
  EXPECT_EQ(json::parse(r.body).at("state"), "paused");
  r = Call(*daemon, "GET", "/v1/jobs/" + id);
  EXPECT_EQ(json::parse(r.body).at("pause_reason"), "paused by a client");
  r = Call(*daemon, "POST", "/v1/jobs/" + id + "/cancel");
  EXPECT_EQ(json::parse(r.body).at("state"), "cancelled");
  r = Call(*daemon, "POST", "/v1/jobs/" + id + "/resume");
  EXPECT_EQ(r.status, 409);
  EXPECT_EQ(ErrorOf(r), "job job-000001 is cancelled: cannot resume it");
  r = Call(*daemon, "GET", "/v1/rig");
  EXPECT_EQ(json::parse(r.body).at("worker"), "idle");
  r = Call(*daemon, "GET", "/v1/events", "", "after=3");
  EXPECT_TRUE(r.event_stream);
  EXPECT_EQ(r.events_after, 3u);
}

TEST_F(SimulatedDaemonTest, RigStatusPreviewsAndAcknowledgements) {
  auto daemon = MakeDaemon();
  const std::string id = daemon->Submit("capture").id;
  const std::string camera = daemon->camera_ids().front();
  ControlResponse r = Call(*daemon, "GET", "/v1/cameras/" + camera + "/preview.png");
  EXPECT_EQ(r.status, 404);
  EXPECT_EQ(ErrorOf(r), "camera \"" + camera + "\": no frame yet");
  r = Call(*daemon, "GET", "/v1/cameras/..%2Fjobs/preview.png");
  EXPECT_EQ(r.status, 404);
  EXPECT_NE(ErrorOf(r).find("not a camera of this rig (its cameras: " + camera), std::string::npos) << r.body;
  r = Call(*daemon, "POST", "/v1/jobs/" + id + "/ack");
  EXPECT_EQ(r.status, 409);
  EXPECT_EQ(ErrorOf(r), "job " + id + " waits for no operator step");
  EXPECT_EQ(Call(*daemon, "GET", "/v1/jobs/" + id + "/ack").status, 405);
  daemon->Start();
  WaitFor(*daemon, id, JobState::kDone);
  r = Call(*daemon, "GET", "/v1/rig");
  const json rig = json::parse(r.body);
  EXPECT_EQ(rig.at("devices").size(), daemon->camera_ids().size() + 4);
  EXPECT_EQ(rig.at("devices").at(0).at("device"), "camera " + camera);
  EXPECT_EQ(rig.at("devices").at(0).at("ok"), true);
  EXPECT_EQ(rig.at("cameras").at(0), camera);
  EXPECT_TRUE(rig.at("devices_read_at").is_string());
  r = Call(*daemon, "GET", "/v1/cameras/" + camera + "/preview.png");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.content_type, "image/png");
  ASSERT_GT(r.body.size(), 8u);
  EXPECT_EQ(r.body.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  // The PNG's size is the preview's (IHDR: width and height, big-endian).
  const auto be32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v = v << 8 | static_cast<unsigned char>(r.body[at + i]);
    return v;
  };
  const CaptureDaemon::Preview preview = *daemon->CameraPreview(camera);
  EXPECT_EQ(be32(16), static_cast<std::uint32_t>(preview.image.width()));
  EXPECT_EQ(be32(20), static_cast<std::uint32_t>(preview.image.height()));
}

TEST_F(SimulatedDaemonTest, ErrorsNameTheFieldOrThePath) {
  auto daemon = MakeDaemon();
  const auto expect = [&](const ControlResponse& r, int status, const std::string& message) {
    EXPECT_EQ(r.status, status) << r.body;
    EXPECT_EQ(ErrorOf(r), message);
  };
  expect(Call(*daemon, "POST", "/v1/jobs", "{\"plan\": "), 400, "request body: not valid JSON");
  expect(Call(*daemon, "POST", "/v1/jobs", R"({"plan": "capture", "out": "/etc"})"), 400,
         "request body: field 'out': unknown member; expected only plan");
  expect(Call(*daemon, "POST", "/v1/jobs", R"({"plan": 3})"), 400, "request body: field 'plan': expected a string, got number 3");
  expect(Call(*daemon, "POST", "/v1/jobs", R"({"plan": "sweep"})"), 400,
         "request body: field 'plan': expected one of \"capture\", \"calibration\", got \"sweep\"");
  expect(Call(*daemon, "POST", "/v1/jobs", "[1]"), 400,
         "request body: expected a JSON object such as {\"plan\": \"capture\"}");
  expect(Call(*daemon, "GET", "/v1/jobs/../../etc/passwd"), 404,
         "path \"/v1/jobs/../../etc/passwd\": not an endpoint (GET /v1/rig, GET|POST /v1/jobs, GET /v1/jobs/ID, POST "
         "/v1/jobs/ID/pause|resume|cancel|ack, GET /v1/cameras/ID/preview.png, GET /v1/events)");
  expect(Call(*daemon, "GET", "/v1/jobs/..%2F..%2Fetc"), 404,
         "job id \"..%2F..%2Fetc\": expected \"job-\" and six digits");
  expect(Call(*daemon, "GET", "/v1/jobs/job-000042"), 404, "no job \"job-000042\"");
  expect(Call(*daemon, "DELETE", "/v1/jobs"), 405, "DELETE /v1/jobs: method not allowed (use GET or POST)");
  expect(Call(*daemon, "GET", "/v1/events", "", "after=-1"), 400,
         "query after: expected an event number, got \"-1\"");
  EXPECT_TRUE(daemon->Jobs().empty());
}

// A request of the hostile kind `kind`, varied by `rng`.
ControlRequest HostileRequest(int kind, std::mt19937& rng) {
  const auto random_bytes = [&](std::size_t n) {
    std::string s(n, '\0');
    for (char& c : s) c = static_cast<char>(rng() & 0xff);
    return s;
  };
  switch (kind) {
    case 0: return {"POST", "/v1/jobs", "", random_bytes(rng() % 200), false};  // not JSON
    case 1: return {"POST", "/v1/jobs", "", std::string(20000, '[') + std::string(20000, ']'), false};  // deep
    case 2: return {"POST", "/v1/jobs", "", R"({"plan": "capture", "path": "../../x"})", false};  // unknown field
    case 3: return {"POST", "/v1/jobs", "", R"({"plan": ")" + std::string(rng() % 5000, 'x') + "\"}", false};
    case 4: return {"GET", "/v1/jobs/" + random_bytes(rng() % 40), "", "", false};
    case 5:
      if (rng() % 2 == 0) return {"GET", "/v1/cameras/" + random_bytes(rng() % 40) + "/preview.png", "", "", false};
      return {"GET", "/" + std::string(rng() % 3000, '.') + "/etc/passwd", "", "", false};
    case 6: return {random_bytes(1 + rng() % 10), "/v1/jobs", "", "", false};  // a method that does not exist
    case 7:  // a command that does not exist, or an acknowledgement nothing asked for
      return {"POST", "/v1/jobs/job-00000" + std::to_string(rng() % 10) + (rng() % 2 ? "/explode" : "/ack"), "", "",
              false};
    case 8: return {"GET", "/v1/events", "after=x" + random_bytes(rng() % 30), "", false};
    default: return {"POST", "/v1/jobs", "", R"({"plan": ["capture"], "plan2": null})", false};
  }
}

// Bytes of the process's resident set.
long ResidentBytes() {
  long pages = 0, resident = 0;
  std::ifstream("/proc/self/statm") >> pages >> resident;
  return resident * ::sysconf(_SC_PAGESIZE);
}

TEST_F(SimulatedDaemonTest, HostileRequestsToTheRouteTableLeaveTheCaptureUnaffected) {
  auto daemon = MakeDaemon();
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  std::mt19937 rng(3);
  const auto send = [&](int count) {
    for (int i = 0; i < count; ++i) {
      const ControlRequest request = HostileRequest(i % 10, rng);
      const ControlResponse r = HandleControlRequest(*daemon, request);
      ASSERT_GE(r.status, 400) << i << ": " << request.method << " " << request.path;
      ASSERT_LT(r.status, 500) << i;
      ASSERT_NE(ErrorOf(r), "(no error member)") << i << ": " << r.body;
    }
  };
  send(9000);  // while the capture runs
  WaitFor(*daemon, id, JobState::kDone);
  // Memory: the same again with the rig idle (the capture's own memory,
  // renderer caches and frames, would hide a leak), grows by little.
  const long resident_before = ResidentBytes();
  send(9000);
  [[maybe_unused]] const long growth = ResidentBytes() - resident_before;
#if !defined(__SANITIZE_ADDRESS__)
  EXPECT_LT(growth, 4l << 20) << "resident set grew by " << growth << " bytes";
#endif
  ASSERT_EQ(daemon->Jobs().size(), 1u);  // nothing hostile became a job
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
}

// Raw bytes to the socket: what a broken or hostile client sends. Returns
// what came back before the server closed the connection (or the timeout).
std::string SendRaw(const fs::path& socket, const std::string& bytes, bool half_close = true) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::snprintf(address.sun_path, sizeof address.sun_path, "%s", socket.c_str());
  if (::connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    ::close(fd);
    return "(no connection)";
  }
  timeval timeout{20, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &timeout, sizeof timeout);
  ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL);
  if (half_close) ::shutdown(fd, SHUT_WR);
  std::string answer;
  char buffer[4096];
  for (ssize_t n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) answer.append(buffer, static_cast<std::size_t>(n));
  ::close(fd);
  return answer;
}

int StatusOf(const std::string& answer) {
  return answer.rfind("HTTP/1.1 ", 0) == 0 ? std::atoi(answer.c_str() + 9) : 0;
}

TEST_F(SimulatedDaemonTest, HostileBytesThroughTheSocketGetAnErrorOrAClosedConnection) {
  auto daemon = MakeDaemon();
  ControlServerOptions server_options;
  server_options.socket = state_ / "control.sock";
  server_options.idle_timeout = std::chrono::seconds(1);
  ControlServer server(*daemon, server_options);
  EXPECT_EQ(fs::status(server_options.socket).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::group_write);
  const std::string id = daemon->Submit("capture").id;
  daemon->Start();
  std::mt19937 rng(5);
  const std::vector<std::string> requests = {
      "GET /v1/nothing HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Length: 99999999999\r\nConnection: close\r\n\r\n{",
      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Length: 7\r\nConnection: close\r\n\r\n{plan:}",
      "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\nConnection: close\r\n\r\n" +
          std::string("10000\r\n") + std::string(0x10000, 'a') + "\r\n10000\r\n" + std::string(0x10000, 'a') +
          "\r\n0\r\n\r\n",
      "GET /v1/jobs/%2e%2e%2f%2e%2e%2fetc HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n",
      "GET / HTTP/1.1\r\nHost: x\r\nX: " + std::string(100000, 'h') + "\r\n\r\n",
      "NOT HTTP AT ALL\r\n\r\n",
  };
  for (int i = 0; i < 1000; ++i) {
    const std::string& request = requests[static_cast<std::size_t>(i) % requests.size()];
    const std::string answer = SendRaw(server_options.socket, request);
    const int status = StatusOf(answer);
    // An HTTP error with a JSON body from the API, an HTTP error from
    // libmicrohttpd for what is not HTTP, or a closed connection.
    if (status != 0) {
      ASSERT_GE(status, 400) << i << ": " << answer.substr(0, 200);
      ASSERT_LT(status, 500) << i << ": " << answer.substr(0, 200);
    }
  }
  // A slow client that sends half a request is dropped after the idle timeout.
  EXPECT_EQ(SendRaw(server_options.socket, "GET /v1/rig HTTP/1.1\r\nHo", false), "");
  const std::string rig = SendRaw(server_options.socket, "GET /v1/rig HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(rig), 200) << rig;
  const std::string big = SendRaw(server_options.socket, requests[1]);
  EXPECT_EQ(StatusOf(big), 413) << big;
  EXPECT_NE(big.find("request body: more than 65536 bytes"), std::string::npos) << big;
  ASSERT_EQ(daemon->Jobs().size(), 1u);
  WaitFor(*daemon, id, JobState::kDone);
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
  server.Stop();
  EXPECT_FALSE(fs::exists(server_options.socket));
}

}  // namespace
}  // namespace mesocap::acquisition
