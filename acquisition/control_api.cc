#include "acquisition/control_api.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <nlohmann/json.hpp>
#include <string_view>
#include <vector>

#include "acquisition/bearer_token.h"
#include "acquisition/capture_plan.h"
#include "acquisition/status_page.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"

namespace mesocap::acquisition {
namespace {

using nlohmann::json;

ControlResponse Json(int status, const json& body) {
  ControlResponse r;
  r.status = status;
  // A message may quote a client's bytes that are not UTF-8.
  r.body = body.dump(-1, ' ', false, json::error_handler_t::replace) + "\n";
  return r;
}

ControlResponse Error(int status, const std::string& message) { return Json(status, {{"error", message}}); }

std::vector<std::string_view> Segments(std::string_view path) {
  std::vector<std::string_view> out;
  std::size_t start = 1;
  while (start <= path.size()) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    out.push_back(path.substr(start, end - start));
    start = end + 1;
  }
  return out;
}

ControlResponse MethodNotAllowed(const ControlRequest& request, const std::string& allowed) {
  return Error(
      405, core::Cut(request.method) + " " + core::Cut(request.path) + ": method not allowed (use " + allowed + ")");
}

ControlResponse Submit(CaptureDaemon& daemon, const ControlRequest& request) {
  const std::string where = "request body";
  json body = json::parse(request.body, nullptr, /*allow_exceptions=*/false);
  if (body.is_discarded()) return Error(400, where + ": not valid JSON");
  try {
    core::RejectDeepNesting(body, where, 8);
    if (!body.is_object()) return Error(400, where + ": expected a JSON object such as {\"plan\": \"capture\"}");
    const core::JsonFieldReader r(body, where);
    r.RejectUnknownMembers({"plan"});
    const std::string plan = r.Choice("plan", kPlanKinds);
    const CaptureJob job = daemon.Submit(plan);
    return Json(201, ToJson(job));
  } catch (const core::Error& e) {
    return Error(400, e.what());
  }
}

ControlResponse JobCommand(const JobCommandResult& result) {
  switch (result.outcome) {
    case JobCommandResult::Outcome::kNoSuchJob:
      return Error(404, result.message);
    case JobCommandResult::Outcome::kNotNow:
      return Error(409, result.message);
    case JobCommandResult::Outcome::kDone:
      break;
  }
  return Json(200, ToJson(result.job));
}

ControlResponse Preview(const CaptureDaemon& daemon, const std::string& camera_id) {
  const std::vector<std::string> ids = daemon.camera_ids();
  if (std::find(ids.begin(), ids.end(), camera_id) == ids.end()) {
    std::string known;
    for (const std::string& id : ids) known += (known.empty() ? "" : ", ") + id;
    return Error(404, "camera " + core::Quoted(camera_id) + ": not a camera of this rig (its cameras: " + known + ")");
  }
  const std::optional<CaptureDaemon::Preview> preview = daemon.CameraPreview(camera_id);
  if (!preview) return Error(404, "camera " + core::Quoted(camera_id) + ": no frame yet");
  ControlResponse r;
  r.content_type = "image/png";
  r.body = core::EncodePreviewPng(preview->image);
  return r;
}

// Reads the query's one parameter `name`=N into `value` (left alone when the
// query is empty); an error response naming the parameter otherwise.
std::optional<ControlResponse> QueryNumber(const ControlRequest& request, std::string_view name,
                                           const std::string& expected, std::uint64_t* value) {
  std::string_view query = request.query;
  const std::string prefix = std::string(name) + "=";
  while (!query.empty()) {
    const std::size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? std::string_view() : query.substr(amp + 1);
    if (pair.substr(0, prefix.size()) != prefix) {
      return Error(400, "query " + core::Quoted(pair) + ": the only parameter is " + prefix + "N");
    }
    const std::string_view text = pair.substr(prefix.size());
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), *value);
    if (ec != std::errc() || end != text.data() + text.size()) {
      return Error(400, "query " + std::string(name) + ": expected " + expected + ", got " + core::Quoted(text));
    }
  }
  return std::nullopt;
}

ControlResponse Events(const ControlRequest& request) {
  std::uint64_t after = 0;
  if (auto error = QueryNumber(request, "after", "an event number", &after)) return *error;
  ControlResponse r;
  r.content_type = "text/event-stream";
  r.event_stream = true;
  r.events_after = after;
  return r;
}

constexpr std::uint64_t kMaxLogLines = 1000;

ControlResponse LogLines(CaptureDaemon& daemon, const ControlRequest& request) {
  std::uint64_t lines = 20;
  const std::string expected = "a number of lines from 1 to " + std::to_string(kMaxLogLines);
  if (auto error = QueryNumber(request, "lines", expected, &lines)) return *error;
  if (lines < 1 || lines > kMaxLogLines) {
    return Error(400, "query lines: expected " + expected + ", got " + std::to_string(lines));
  }
  json out = json::array();
  for (const DaemonEvent& e : daemon.events().Latest(lines, {"log", "fault"})) {
    json line = {{"number", e.number}, {"type", e.type}, {"message", e.data.value("message", "")}};
    if (e.data.contains("job")) line["job"] = e.data["job"];
    out.push_back(std::move(line));
  }
  return Json(200, {{"lines", out}, {"last_event", daemon.events().last_number()}});
}

ControlResponse Forget(CaptureDaemon& daemon, const ControlRequest& request, const std::string& id) {
  std::uint64_t delete_session = 0;
  if (auto error = QueryNumber(request, "delete_session", "0 or 1", &delete_session)) return *error;
  if (delete_session > 1)
    return Error(400, "query delete_session: expected 0 or 1, got " + std::to_string(delete_session));
  try {
    const JobCommandResult result = daemon.Forget(id, delete_session == 1);
    if (result.outcome != JobCommandResult::Outcome::kDone) return JobCommand(result);
  } catch (const core::Error& e) {
    return Error(500, e.what());
  }
  return Json(200, {{"forgotten", id}, {"session", delete_session == 1 ? "deleted" : "kept"}});
}

ControlResponse StatusPage() {
  ControlResponse r;
  r.content_type = "text/html; charset=utf-8";
  r.body = std::string(StatusPageHtml());
  // Its own inline script and style and requests to this origin only; the
  // token in the address's fragment is never sent, not even as a referrer.
  r.headers = {{"Content-Security-Policy",
                "default-src 'none'; script-src 'unsafe-inline'; style-src 'unsafe-inline'; connect-src 'self'; "
                "img-src 'self' blob:; base-uri 'none'; form-action 'none'; frame-ancestors 'none'"},
               {"Referrer-Policy", "no-referrer"},
               {"X-Content-Type-Options", "nosniff"}};
  return r;
}

bool IsStatusPage(std::string_view path) { return path == "/" || path == "/index.html"; }

ControlResponse Unauthorized(const std::string& message, bool wrong_token) {
  ControlResponse r = Error(401, message);
  r.headers = {{"WWW-Authenticate",
                wrong_token ? "Bearer realm=\"mesocapd\", error=\"invalid_token\"" : "Bearer realm=\"mesocapd\""}};
  return r;
}

ControlResponse TooLarge() {
  return Error(413, "request body: more than " + std::to_string(kMaxRequestBodyBytes) + " bytes");
}

}  // namespace

std::optional<ControlResponse> RefusedAccess(const ControlRequest& request, std::string_view bearer_token) {
  if (!request.over_tcp) return std::nullopt;  // the Unix socket's mode is its guard
  if (request.method == "GET" && IsStatusPage(request.path)) return std::nullopt;  // holds no data
  if (request.authorization.empty()) {
    return Unauthorized(
        "missing Authorization header: expected \"Authorization: Bearer TOKEN\" with the token in "
        "mesocapd's control.token",
        false);
  }
  // "Bearer" is case-insensitive (RFC 7235); one or more spaces follow it.
  std::string_view value = request.authorization;
  constexpr std::string_view kScheme = "bearer ";
  bool bearer = value.size() > kScheme.size();
  for (std::size_t i = 0; bearer && i < kScheme.size(); ++i) {
    bearer = std::tolower(static_cast<unsigned char>(value[i])) == kScheme[i];
  }
  if (!bearer) return Unauthorized("Authorization header: expected \"Bearer TOKEN\"", false);
  value.remove_prefix(kScheme.size());
  while (!value.empty() && value.front() == ' ') value.remove_prefix(1);
  while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.remove_suffix(1);
  // Without a token of its own the daemon admits nobody over TCP.
  if (bearer_token.empty() || !BearerTokensEqual(value, bearer_token)) {
    return Unauthorized("wrong bearer token: use the one in mesocapd's control.token", true);
  }
  return std::nullopt;
}

ControlResponse HandleControlRequest(CaptureDaemon& daemon, const ControlRequest& request,
                                     std::string_view bearer_token) {
  if (auto refused = RefusedAccess(request, bearer_token)) return *refused;
  if (request.body_too_large) return TooLarge();
  const std::string_view path = request.path;
  if (path.empty() || path[0] != '/') return Error(400, "path " + core::Quoted(path) + ": expected one from /v1/");
  const bool get = request.method == "GET", post = request.method == "POST", del = request.method == "DELETE";
  if (IsStatusPage(path)) {
    if (!get) return MethodNotAllowed(request, "GET");
    return StatusPage();
  }
  const std::vector<std::string_view> s = Segments(path);
  if (s.size() >= 1 && s[0] == "v1") {
    if (s.size() == 2 && s[1] == "rig") {
      if (!get) return MethodNotAllowed(request, "GET");
      const std::string running = daemon.running_job();
      const CaptureDaemon::RigStatus status = daemon.DeviceStates();
      json devices = json::array();
      for (const drivers::DeviceState& d : status.devices) {
        devices.push_back({{"device", d.device}, {"kind", d.kind}, {"ok", d.ok}, {"state", d.state}});
      }
      return Json(200, {{"rig", daemon.rig_name()},
                        {"worker", running.empty() ? "idle" : "running"},
                        {"running_job", running.empty() ? json(nullptr) : json(running)},
                        {"devices", devices},
                        {"devices_read_at", status.read_at.empty() ? json(nullptr) : json(status.read_at)},
                        {"cameras", daemon.camera_ids()},
                        {"last_event", daemon.events().last_number()}});
    }
    if (s.size() == 2 && s[1] == "events") {
      if (!get) return MethodNotAllowed(request, "GET");
      return Events(request);
    }
    if (s.size() == 2 && s[1] == "log") {
      if (!get) return MethodNotAllowed(request, "GET");
      return LogLines(daemon, request);
    }
    if (s.size() == 2 && s[1] == "jobs") {
      if (get) {
        json jobs = json::array();
        for (const CaptureJob& job : daemon.Jobs()) jobs.push_back(ToJson(job));
        return Json(200, {{"jobs", jobs}, {"last_event", daemon.events().last_number()}});
      }
      if (post) return Submit(daemon, request);
      return MethodNotAllowed(request, "GET or POST");
    }
    if (s.size() == 4 && s[1] == "cameras" && s[3] == "preview.png") {
      if (!get) return MethodNotAllowed(request, "GET");
      return Preview(daemon, std::string(s[2]));
    }
    if ((s.size() == 3 || s.size() == 4) && s[1] == "jobs") {
      const std::string id(s[2]);
      if (!IsJobId(id)) return Error(404, "job id " + core::Quoted(id) + ": expected \"job-\" and at least six digits");
      if (s.size() == 3) {
        if (del) return Forget(daemon, request, id);
        if (!get) return MethodNotAllowed(request, "GET or DELETE");
        const std::optional<CaptureJob> job = daemon.Job(id);
        if (!job) return Error(404, "no job " + core::Quoted(id));
        json body = ToJson(*job);
        body["last_event"] = daemon.events().last_number();
        return Json(200, body);
      }
      const std::string_view command = s[3];
      if (command == "pause" || command == "resume" || command == "cancel" || command == "ack") {
        if (!post) return MethodNotAllowed(request, "POST");
        if (command == "pause") return JobCommand(daemon.Pause(id));
        if (command == "resume") return JobCommand(daemon.Resume(id));
        if (command == "ack") return JobCommand(daemon.Ack(id));
        return JobCommand(daemon.Cancel(id));
      }
      return Error(404, "job command " + core::Quoted(command) + ": expected pause, resume, cancel or ack");
    }
  }
  return Error(404, "path " + core::Quoted(path) +
                        ": not an endpoint (GET /, GET /v1/rig, GET|POST /v1/jobs, GET|DELETE /v1/jobs/ID, POST "
                        "/v1/jobs/ID/pause|resume|cancel|ack, GET /v1/cameras/ID/preview.png, GET /v1/events, "
                        "GET /v1/log)");
}

std::string EventStreamMessage(const DaemonEvent& event) {
  return "id: " + std::to_string(event.number) + "\nevent: " + event.type +
         "\ndata: " + event.data.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n\n";
}

}  // namespace mesocap::acquisition
