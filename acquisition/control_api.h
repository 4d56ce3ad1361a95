// The capture daemon's control API as a pure function of a request: method,
// path, headers that matter and body in; status, content type and body out.
// The HTTP server (acquisition/control_server.h) only carries requests to
// it, so every route, every error and who may ask is testable without a
// socket.
//
//   GET  / and /index.html           the status page (acquisition/status_page.h)
//   GET  /v1/rig                     the rig, each device's state, what the worker does
//   GET  /v1/jobs                    every job, in submission order
//   POST /v1/jobs  {"plan": KIND}    submit a job -> 201 and its record
//   GET  /v1/jobs/ID                 one job (steps, ETA, frames, pause reason)
//   DELETE /v1/jobs/ID[?delete_session=1]  forget a finished job (its session stays without the query)
//   POST /v1/jobs/ID/pause|resume|cancel
//   POST /v1/jobs/ID/ack             the operator did what the job's prompt asked
//   GET  /v1/cameras/ID/preview.png  a camera's latest frame, scaled down
//   GET  /v1/events?after=N          server-sent events after event N
//   GET  /v1/log?lines=N             the latest N log and fault messages
//
// Every error is {"error": MESSAGE} with a message naming the field or the
// path, and a 4xx status; the daemon never learns a path from a client.
//
// A request over loopback TCP must carry "Authorization: Bearer TOKEN"
// (acquisition/bearer_token.h), all but GET of the status page's document,
// which holds no data; a request over the Unix socket needs none.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "acquisition/capture_daemon.h"

namespace mesocap::acquisition {

inline constexpr std::size_t kMaxRequestBodyBytes = 64 * 1024;

struct ControlRequest {
  std::string method;           // "GET", "POST", ...
  std::string path;             // without the query
  std::string query;            // after '?', undecoded
  std::string body;             // at most kMaxRequestBodyBytes: the server answers 413 to a longer one
  bool body_too_large = false;  // for the server's own use
  bool over_tcp = false;        // came to the loopback TCP listener (else the Unix socket)
  std::string authorization{};  // the Authorization header; empty when none came
};

struct ControlResponse {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;  // beyond Content-Type
  // For GET /v1/events: the server streams the daemon's events after
  // `events_after` instead of sending `body`.
  bool event_stream = false;
  std::uint64_t events_after = 0;
};

// `bearer_token` is the token a request over TCP must carry; with none (the
// daemon has no TCP listener) every request over TCP is refused.
ControlResponse HandleControlRequest(CaptureDaemon& daemon, const ControlRequest& request,
                                     std::string_view bearer_token = {});

// The 401 a request over TCP without the right bearer token gets, or none.
// HandleControlRequest asks this first; the server also asks it once the
// headers are in, to refuse before reading a body.
std::optional<ControlResponse> RefusedAccess(const ControlRequest& request, std::string_view bearer_token);

// One event in the text/event-stream format ("id:", "event:", "data:").
std::string EventStreamMessage(const DaemonEvent& event);

}  // namespace mesocap::acquisition
