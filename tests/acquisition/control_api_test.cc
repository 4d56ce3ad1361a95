// The control API: each endpoint against the daemon's state, who may ask
// over TCP, and 10 000 malformed or hostile requests while a capture runs
// (9000 to the route table, 1000 raw through the Unix socket and the TCP
// port), bad bearer tokens among them: each gets a 4xx JSON error naming
// what is wrong, or its connection is closed; the daemon stays up, and the
// capture ends with the session an undisturbed run records. 9000 more with
// the rig idle show the daemon's memory stays bounded.
#include "acquisition/control_api.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>
#include <random>

#include "acquisition/control_server.h"
#include "acquisition/status_page.h"
#include "tests/acquisition/raw_http.h"
#include "tests/acquisition/simulated_daemon.h"

namespace mesocap::acquisition {
namespace {

using nlohmann::json;

const std::string kToken(64, 'a');

ControlResponse Call(CaptureDaemon& daemon, const std::string& method, const std::string& path,
                     const std::string& body = "", const std::string& query = "") {
  return HandleControlRequest(daemon, {method, path, query, body, false});
}

// A request to the loopback TCP listener, with `authorization` as its
// Authorization header (none when empty).
ControlResponse CallOverTcp(CaptureDaemon& daemon, const std::string& method, const std::string& path,
                            const std::string& authorization, const std::string& body = "") {
  ControlRequest request{method, path, "", body, false};
  request.over_tcp = true;
  request.authorization = authorization;
  return HandleControlRequest(daemon, request, kToken);
}

std::string HeaderOf(const ControlResponse& r, const std::string& name) {
  for (const auto& [key, value] : r.headers) {
    if (key == name) return value;
  }
  return "(no " + name + ")";
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
  expect(Call(*daemon, "POST", "/v1/jobs", R"({"plan": 3})"), 400,
         "request body: field 'plan': expected a string, got number 3");
  expect(Call(*daemon, "POST", "/v1/jobs", R"({"plan": "sweep"})"), 400,
         "request body: field 'plan': expected one of \"capture\", \"btf\", \"calibration\", got \"sweep\"");
  expect(Call(*daemon, "POST", "/v1/jobs", "[1]"), 400,
         "request body: expected a JSON object such as {\"plan\": \"capture\"}");
  expect(Call(*daemon, "GET", "/v1/jobs/../../etc/passwd"), 404,
         "path \"/v1/jobs/../../etc/passwd\": not an endpoint (GET /, GET /v1/rig, GET|POST /v1/jobs, GET|DELETE "
         "/v1/jobs/ID, POST /v1/jobs/ID/pause|resume|cancel|ack, GET /v1/cameras/ID/preview.png, GET /v1/events, "
         "GET /v1/log)");
  expect(Call(*daemon, "GET", "/v1/jobs/..%2F..%2Fetc"), 404,
         "job id \"..%2F..%2Fetc\": expected \"job-\" and at least six digits");
  expect(Call(*daemon, "GET", "/v1/jobs/job-000042"), 404, "no job \"job-000042\"");
  expect(Call(*daemon, "DELETE", "/v1/jobs"), 405, "DELETE /v1/jobs: method not allowed (use GET or POST)");
  expect(Call(*daemon, "GET", "/v1/events", "", "after=-1"), 400, "query after: expected an event number, got \"-1\"");
  expect(Call(*daemon, "GET", "/v1/log", "", "lines=0"), 400,
         "query lines: expected a number of lines from 1 to 1000, got 0");
  expect(Call(*daemon, "GET", "/v1/log", "", "lines=x"), 400,
         "query lines: expected a number of lines from 1 to 1000, got \"x\"");
  expect(Call(*daemon, "GET", "/v1/log", "", "after=3"), 400, "query \"after=3\": the only parameter is lines=N");
  expect(Call(*daemon, "POST", "/"), 405, "POST /: method not allowed (use GET)");
  EXPECT_TRUE(daemon->Jobs().empty());
}

TEST_F(SimulatedDaemonTest, OverTcpEveryRequestButTheStatusPageNeedsTheBearerToken) {
  auto daemon = MakeDaemon();
  const auto expect_refused = [&](const ControlResponse& r, const std::string& message, const std::string& challenge) {
    EXPECT_EQ(r.status, 401) << r.body;
    EXPECT_EQ(ErrorOf(r), message);
    EXPECT_EQ(HeaderOf(r, "WWW-Authenticate"), challenge);
  };
  const std::string missing =
      "missing Authorization header: expected \"Authorization: Bearer TOKEN\" with the token in mesocapd's "
      "control.token";
  const std::string wrong = "wrong bearer token: use the one in mesocapd's control.token";
  const std::string plain = "Bearer realm=\"mesocapd\"";
  const std::string invalid = "Bearer realm=\"mesocapd\", error=\"invalid_token\"";
  expect_refused(CallOverTcp(*daemon, "GET", "/v1/rig", ""), missing, plain);
  expect_refused(CallOverTcp(*daemon, "GET", "/v1/rig", "Bearer " + std::string(64, 'b')), wrong, invalid);
  // One digit off, a prefix, the token twice: wrong all the same.
  expect_refused(CallOverTcp(*daemon, "GET", "/v1/rig", "Bearer " + kToken.substr(1) + "b"), wrong, invalid);
  expect_refused(CallOverTcp(*daemon, "GET", "/v1/rig", "Bearer " + kToken.substr(0, 63)), wrong, invalid);
  expect_refused(CallOverTcp(*daemon, "GET", "/v1/rig", "Bearer " + kToken + kToken), wrong, invalid);
  expect_refused(CallOverTcp(*daemon, "GET", "/v1/rig", "Basic " + kToken),
                 "Authorization header: expected \"Bearer TOKEN\"", plain);
  expect_refused(CallOverTcp(*daemon, "GET", "/v1/rig", "Bearer "), "Authorization header: expected \"Bearer TOKEN\"",
                 plain);
  // A refused request does nothing: no job, whatever its body.
  expect_refused(CallOverTcp(*daemon, "POST", "/v1/jobs", "", R"({"plan": "capture"})"), missing, plain);
  expect_refused(CallOverTcp(*daemon, "POST", "/v1/jobs", "Bearer x", R"({"plan": "capture"})"), wrong, invalid);
  EXPECT_TRUE(daemon->Jobs().empty());
  // Refused before a body over the limit is looked at.
  ControlRequest large{"POST", "/v1/jobs", "", "", true};
  large.over_tcp = true;
  EXPECT_EQ(HandleControlRequest(*daemon, large, kToken).status, 401);
  large.authorization = "Bearer " + kToken;
  EXPECT_EQ(HandleControlRequest(*daemon, large, kToken).status, 413);

  // The right token, the scheme in any case.
  ControlResponse r = CallOverTcp(*daemon, "POST", "/v1/jobs", "Bearer " + kToken, R"({"plan": "capture"})");
  EXPECT_EQ(r.status, 201) << r.body;
  r = CallOverTcp(*daemon, "GET", "/v1/jobs/job-000001", "bearer  " + kToken);
  EXPECT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(json::parse(r.body).at("state"), "queued");
  // A daemon without a token of its own admits nobody over TCP.
  ControlRequest tokenless{"GET", "/v1/rig", "", "", false};
  tokenless.over_tcp = true;
  tokenless.authorization = "Bearer ";
  EXPECT_EQ(HandleControlRequest(*daemon, tokenless).status, 401);
  tokenless.authorization = "Bearer " + kToken;
  EXPECT_EQ(HandleControlRequest(*daemon, tokenless).status, 401);

  // The status page's document holds no data: served without a token, by
  // GET only; over the Unix socket nothing needs one.
  for (const char* path : {"/", "/index.html"}) {
    r = CallOverTcp(*daemon, "GET", path, "");
    EXPECT_EQ(r.status, 200) << path;
    EXPECT_EQ(r.content_type, "text/html; charset=utf-8");
    EXPECT_EQ(r.body, std::string(StatusPageHtml()));
    EXPECT_NE(r.body.find("<title>mesocapd status</title>"), std::string::npos);
    EXPECT_EQ(HeaderOf(r, "Content-Security-Policy").find("default-src 'none'"), 0u);
  }
  expect_refused(CallOverTcp(*daemon, "POST", "/", ""), missing, plain);
  expect_refused(CallOverTcp(*daemon, "HEAD", "/", ""), missing, plain);
  EXPECT_EQ(Call(*daemon, "GET", "/v1/rig").status, 200);
  EXPECT_EQ(Call(*daemon, "GET", "/").status, 200);
}

TEST_F(SimulatedDaemonTest, TheLogEndpointGivesTheLatestLogAndFaultMessages) {
  auto daemon = MakeDaemon();
  daemon->Submit("capture");
  daemon->Submit("calibration");
  ControlResponse r = Call(*daemon, "GET", "/v1/log");
  ASSERT_EQ(r.status, 200) << r.body;
  json lines = json::parse(r.body).at("lines");
  ASSERT_EQ(lines.size(), 2u) << r.body;
  EXPECT_EQ(lines[0].at("message"), "job-000001 submitted (capture)");
  EXPECT_EQ(lines[1].at("message"), "job-000002 submitted (calibration)");
  EXPECT_EQ(lines[1].at("type"), "log");
  EXPECT_LT(lines[0].at("number"), lines[1].at("number"));
  lines = json::parse(Call(*daemon, "GET", "/v1/log", "", "lines=1").body).at("lines");
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_EQ(lines[0].at("message"), "job-000002 submitted (calibration)");
}

// A request of the hostile kind `kind`, varied by `rng`.
ControlRequest HostileRequest(int kind, std::mt19937& rng) {
  const auto random_bytes = [&](std::size_t n) {
    std::string s(n, '\0');
    for (char& c : s) c = static_cast<char>(rng() & 0xff);
    return s;
  };
  switch (kind) {
    case 0:
      return {"POST", "/v1/jobs", "", random_bytes(rng() % 200), false};  // not JSON
    case 1:
      return {"POST", "/v1/jobs", "", std::string(20000, '[') + std::string(20000, ']'), false};  // deep
    case 2:
      return {"POST", "/v1/jobs", "", R"({"plan": "capture", "path": "../../x"})", false};  // unknown field
    case 3:
      return {"POST", "/v1/jobs", "", R"({"plan": ")" + std::string(rng() % 5000, 'x') + "\"}", false};
    case 4:
      return {"GET", "/v1/jobs/" + random_bytes(rng() % 40), "", "", false};
    case 5:
      if (rng() % 2 == 0) return {"GET", "/v1/cameras/" + random_bytes(rng() % 40) + "/preview.png", "", "", false};
      return {"GET", "/" + std::string(rng() % 3000, '.') + "/etc/passwd", "", "", false};
    case 6:
      return {random_bytes(1 + rng() % 10), "/v1/jobs", "", "", false};  // a method that does not exist
    case 7:  // a command that does not exist, or an acknowledgement nothing asked for
      return {"POST", "/v1/jobs/job-00000" + std::to_string(rng() % 10) + (rng() % 2 ? "/explode" : "/ack"), "", "",
              false};
    case 8:
      return {"GET", "/v1/events", "after=x" + random_bytes(rng() % 30), "", false};
    case 9:
      return {"POST", "/v1/jobs", "", R"({"plan": ["capture"], "plan2": null})", false};
    default: {
      // Over TCP, a request that would succeed but for its token: none, a
      // wrong one, one digit off, random bytes.
      static const char* const kPaths[] = {"/v1/rig", "/v1/jobs", "/v1/jobs/job-000001", "/v1/log", "/v1/events"};
      ControlRequest request{"GET", kPaths[rng() % 5], "", "", false};
      if (rng() % 2 == 0) request = {"POST", "/v1/jobs", "", R"({"plan": "capture"})", false};
      request.over_tcp = true;
      std::string wrong = kToken;
      wrong[rng() % wrong.size()] = 'b';
      switch (kind) {
        case 10:
          break;
        case 11:
          request.authorization = "Bearer " + wrong;
          break;
        default:
          request.authorization = (rng() % 2 ? "Bearer " : "") + random_bytes(rng() % 100);
          break;
      }
      return request;
    }
  }
}

constexpr int kHostileKinds = 13;

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
      const ControlRequest request = HostileRequest(i % kHostileKinds, rng);
      const ControlResponse r = HandleControlRequest(*daemon, request, kToken);
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

TEST_F(SimulatedDaemonTest, HostileBytesThroughTheSocketAndThePortGetAnErrorOrAClosedConnection) {
  auto daemon = MakeDaemon();
  ControlServerOptions server_options;
  server_options.socket = state_ / "control.sock";
  server_options.tcp_port = 0;
  server_options.bearer_token = kToken;
  server_options.idle_timeout = std::chrono::seconds(1);
  ControlServer server(*daemon, server_options);
  const std::uint16_t port = server.tcp_port();
  ASSERT_NE(port, 0);
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
  // Requests the daemon would carry out but for their token: over TCP only.
  const std::string submit = "POST /v1/jobs HTTP/1.1\r\nHost: x\r\nContent-Length: 19\r\nConnection: close\r\n";
  const std::vector<std::string> tokenless = {
      submit + "\r\n{\"plan\": \"capture\"}",
      submit + "Authorization: Bearer " + std::string(64, 'b') + "\r\n\r\n{\"plan\": \"capture\"}",
      submit + "Authorization: Basic " + kToken + "\r\n\r\n{\"plan\": \"capture\"}",
      "GET /v1/jobs HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer " + kToken.substr(1) + "\r\nConnection: close\r\n\r\n",
      "GET /v1/events HTTP/1.1\r\nHost: x\r\nAuthorization: " + std::string(3000, 'A') +
          "\r\nConnection: close\r\n\r\n",
  };
  for (int i = 0; i < 1000; ++i) {
    const std::size_t n = static_cast<std::size_t>(i / 3);
    std::string answer;
    bool needs_token = false;
    if (i % 3 == 0) {
      answer = SendRaw(server_options.socket, requests[n % requests.size()]);
    } else if (i % 3 == 1) {
      answer = SendRaw(ConnectTcp(port), requests[n % requests.size()]);
    } else {
      answer = SendRaw(ConnectTcp(port), tokenless[n % tokenless.size()]);
      needs_token = true;
    }
    const int status = StatusOf(answer);
    if (needs_token) {
      ASSERT_EQ(status, 401) << i << ": " << answer.substr(0, 300);
      ASSERT_NE(answer.find("WWW-Authenticate: Bearer"), std::string::npos) << i << ": " << answer.substr(0, 300);
    } else if (status != 0) {
      // An HTTP error with a JSON body from the API, an HTTP error from
      // libmicrohttpd for what is not HTTP, or a closed connection.
      ASSERT_GE(status, 400) << i << ": " << answer.substr(0, 200);
      ASSERT_LT(status, 500) << i << ": " << answer.substr(0, 200);
    }
  }
  // A slow client that sends half a request is dropped after the idle timeout.
  EXPECT_EQ(SendRaw(server_options.socket, "GET /v1/rig HTTP/1.1\r\nHo", false), "");
  const std::string rig =
      SendRaw(server_options.socket, "GET /v1/rig HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n");
  EXPECT_EQ(StatusOf(rig), 200) << rig;
  const std::string big = SendRaw(server_options.socket, requests[1]);
  EXPECT_EQ(StatusOf(big), 413) << big;
  EXPECT_NE(big.find("request body: more than 65536 bytes"), std::string::npos) << big;
  ASSERT_EQ(daemon->Jobs().size(), 1u);  // no tokenless submit became a job
  WaitFor(*daemon, id, JobState::kDone);
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
  server.Stop();
  EXPECT_FALSE(fs::exists(server_options.socket));
  EXPECT_EQ(ConnectTcp(port), -1);
}

}  // namespace
}  // namespace mesocap::acquisition
