// `mesocap capture submit|list|status|watch|pause|resume|cancel|ack|forget`: the
// capture daemon's client (docs/DAEMON.md). Each subcommand is one request to
// mesocapd's control API over its Unix socket (or its loopback TCP port with
// --url and --token-file); `watch` follows a job's
// progress from the event stream until it is done, failed or cancelled.
#include <unistd.h>

#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "acquisition/capture_plan.h"
#include "apps/mesocap/command.h"
#include "apps/mesocap/control_client.h"
#include "core/error.h"

namespace mesocap {
namespace {

using nlohmann::json;

struct CaptureClientOptions {
  std::filesystem::path socket = DefaultControlSocket();
  std::string url;                   // instead of the socket
  std::filesystem::path token_file;  // with url
  bool json_output = false;
  std::string plan = "capture";
  std::string id;
  bool delete_session = false;

  ControlClient Client() const {
    if (url.empty() && token_file.empty()) return ControlClient(ControlEndpoint{socket, {}, {}});
    return ControlClient(LoopbackControlEndpoint(url, token_file));
  }
};

std::string Duration(double seconds) {
  const long s = static_cast<long>(seconds + 0.5);
  char text[32];
  if (s >= 3600) {
    std::snprintf(text, sizeof text, "%ldh%02ldm", s / 3600, s / 60 % 60);
  } else {
    std::snprintf(text, sizeof text, "%ldm%02lds", s / 60, s % 60);
  }
  return text;
}

std::string Steps(const json& job) {
  return std::to_string(job.value("steps_done", 0)) + "/" + std::to_string(job.value("steps_total", 0));
}

// One line: "job-000001 running 12/40 steps, 480 frames (0 dropped, 1 retried), ETA 1m20s".
std::string Summary(const json& job) {
  std::string line = job.value("id", "") + " " + job.value("state", "") + " (" + job.value("plan", "") + ") " +
                     Steps(job) + " steps, " + std::to_string(job.value("frames", 0)) + " frames (" +
                     std::to_string(job.value("dropped_frames", 0)) + " dropped, " +
                     std::to_string(job.value("retries", 0)) + " retried)";
  if (job.value("state", "") == "running" && job.contains("eta_s") && job["eta_s"].is_number()) {
    line += ", ETA " + Duration(job["eta_s"].get<double>());
  }
  if (!job.value("operator_prompt", "").empty()) {
    line += "; the operator is asked: " + job.value("operator_prompt", "") + " (when done: mesocap capture ack " +
            job.value("id", "") + ")";
  } else if (!job.value("pause_reason", "").empty()) {
    line += "; paused: " + job.value("pause_reason", "");
  }
  if (!job.value("error", "").empty()) line += "; error: " + job.value("error", "");
  return line;
}

void Print(const json& value, bool as_json, const std::string& text) {
  std::cout << (as_json ? value.dump(2) : text) << "\n";
}

bool Finished(const json& job) {
  const std::string state = job.value("state", "");
  return state == "done" || state == "failed" || state == "cancelled";
}

// Follows the job until it finishes; the exit status says how it ended.
void Watch(const CaptureClientOptions& o) {
  const ControlClient client = o.Client();
  json job = client.Get("/v1/jobs/" + o.id);
  const bool tty = ::isatty(STDOUT_FILENO) != 0;
  std::string last_line;
  const auto show = [&](const json& j) {
    const std::string line = Summary(j);
    if (line == last_line) return;
    last_line = line;
    if (tty) {
      const double total = std::max(1, j.value("steps_total", 0));
      const int filled = static_cast<int>(30 * j.value("steps_done", 0) / total);
      std::cout << "\r\033[K[" << std::string(filled, '#') << std::string(30 - filled, '.') << "] " << line
                << std::flush;
    } else {
      std::cout << line << "\n" << std::flush;
    }
  };
  show(job);
  if (!Finished(job)) {
    const std::uint64_t after = job.value("last_event", std::uint64_t{0});
    client.Stream("/v1/events?after=" + std::to_string(after), [&](std::string_view type, const json& data) {
      if ((type == "job" || type == "step" || type == "prompt") && data.value("id", "") == o.id) {
        job = data;
        show(job);
      }
      return !Finished(job);
    });
  }
  if (tty) std::cout << "\n";
  if (!Finished(job)) throw core::Error("mesocapd stopped while " + o.id + " was " + job.value("state", "?"));
  if (job.value("state", "") != "done") throw core::Error(o.id + " " + job.value("state", "") + ": " + Summary(job));
}

}  // namespace

void RegisterCaptureCommand(CLI::App& app) {
  auto o = std::make_shared<CaptureClientOptions>();
  CLI::App* group = app.add_subcommand("capture", "Talk to mesocapd, the capture daemon: submit and steer captures");
  group->require_subcommand(1);
  const auto address = [o](CLI::App* sub) {
    CLI::Option* socket =
        sub->add_option("--socket", o->socket, "mesocapd's control socket ($MESOCAP_SOCKET overrides the default)")
            ->default_str(kShippedControlSocket);  // the help shows the same default whatever the environment
    CLI::Option* url = sub->add_option("--url", o->url,
                                       "mesocapd's loopback TCP address, http://127.0.0.1:PORT (mesocapd --tcp-port), "
                                       "instead of its socket");
    CLI::Option* token = sub->add_option("--token-file", o->token_file,
                                         "with --url: the file holding mesocapd's bearer token (STATE/control.token)");
    url->excludes(socket)->needs(token);
    token->needs(url);
  };
  const auto common = [o, address](CLI::App* sub) {
    address(sub);
    sub->add_flag("--json", o->json_output, "print the daemon's JSON answer");
  };
  const auto job_id = [o](CLI::App* sub) {
    sub->add_option("id", o->id, "the job's id (job-NNNNNN, more digits past 999999)")->required();
  };

  CLI::App* submit = group->add_subcommand("submit", "Queue a capture session; prints its job id");
  common(submit);
  submit
      ->add_option("--plan", o->plan,
                   "capture (BTF images, laser calibration and sweeps), btf (the BTF images alone) or calibration")
      ->check(CLI::IsMember(acquisition::kPlanKinds))
      ->capture_default_str();
  submit->callback([o] {
    const json job = o->Client().Post("/v1/jobs", {{"plan", o->plan}});
    Print(job, o->json_output, job.value("id", ""));
  });

  CLI::App* list = group->add_subcommand("list", "Every job, in submission order");
  common(list);
  list->callback([o] {
    const json answer = o->Client().Get("/v1/jobs");
    std::string text;
    for (const json& job : answer.at("jobs")) text += (text.empty() ? "" : "\n") + Summary(job);
    Print(answer, o->json_output, text.empty() ? "no jobs" : text);
  });

  CLI::App* status = group->add_subcommand("status", "One job: state, steps, frames, ETA, why it is paused");
  common(status);
  job_id(status);
  status->callback([o] {
    const json job = o->Client().Get("/v1/jobs/" + o->id);
    Print(job, o->json_output, Summary(job));
  });

  for (const char* command : {"pause", "resume", "cancel", "ack"}) {
    const std::string name = command;
    CLI::App* sub = group->add_subcommand(
        name, name == "pause"    ? "Pause a job (a running one stops after its current step)"
              : name == "resume" ? "Resume a paused job (one paused on a fault is tried again at once)"
              : name == "ack"    ? "Say that the operator step a job asks for is done (its capture goes on)"
                                 : "Cancel a job (a running one stops after its current step; its session stays)");
    common(sub);
    job_id(sub);
    sub->callback([o, name] {
      const json job = o->Client().Post("/v1/jobs/" + o->id + "/" + name, json::object());
      Print(job, o->json_output, Summary(job));
    });
  }

  CLI::App* forget = group->add_subcommand(
      "forget",
      "Forget a finished (done, failed or cancelled) job: its record goes from the queue; its session stays in "
      "STATE/sessions/ID unless --delete-session is given. Its number is not given to a later job while the "
      "session stays");
  address(forget);
  job_id(forget);
  forget->add_flag("--delete-session", o->delete_session, "delete the job's capture session too");
  forget->callback([o] {
    const json answer = o->Client().Delete("/v1/jobs/" + o->id + (o->delete_session ? "?delete_session=1" : ""));
    std::cout << answer.value("forgotten", o->id) << " forgotten; its session "
              << (answer.value("session", "") == "deleted" ? "deleted" : "stays in STATE/sessions/" + o->id) << "\n";
  });

  CLI::App* watch = group->add_subcommand("watch", "Follow a job's progress until it ends (exit 0 when done)");
  address(watch);
  job_id(watch);
  watch->callback([o] { Watch(*o); });
}

}  // namespace mesocap
