// mesocapd: the capture session daemon (docs/DAEMON.md). Opens the rig once,
// runs a queue of capture jobs from its state directory one at a time, and
// serves the control API on a Unix socket, and with --tcp-port on loopback
// TCP with a bearer token (and the status page). Started in the foreground or by
// systemd (Type=notify: READY once the socket listens, WATCHDOG pings while
// the main loop runs). SIGTERM or SIGINT lets the running step finish and
// journal, then exits; the next start resumes that job.
#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <systemd/sd-daemon.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <memory>
#include <optional>
#include <string>

#include "acquisition/bearer_token.h"
#include "acquisition/capture_daemon.h"
#include "acquisition/control_server.h"
#include "apps/mesocap/scene_option.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/logging.h"
#include "core/version.h"
#include "pipelines/rig_station.h"
#include "pipelines/simulated_station.h"
#include "sim/shipped_rigs.h"

namespace {

namespace fs = std::filesystem;
using namespace mesocap;

struct DaemonCommandOptions {
  pipelines::SimulatedStationOptions station;
  fs::path calibration;  // a real rig's
  fs::path state;
  fs::path socket;                        // default: STATE/control.sock
  std::optional<std::uint16_t> tcp_port;  // 0: one the kernel picks
  double fault_retry_s = 30;
  bool prompt_operator = false;
  bool rotate_token = false;
};

// Waits for SIGTERM or SIGINT, pinging systemd's watchdog at half its
// interval meanwhile. The signals are blocked in every thread (main blocks
// them before any thread starts), so only this wait sees them.
int WaitForStop(const sigset_t& signals) {
  std::uint64_t watchdog_us = 0;
  const bool watchdog = sd_watchdog_enabled(0, &watchdog_us) > 0 && watchdog_us > 0;
  const std::uint64_t wait_us = watchdog ? watchdog_us / 2 : 1000000;
  timespec timeout{static_cast<time_t>(wait_us / 1000000), static_cast<long>(wait_us % 1000000) * 1000};
  while (true) {
    const int signal = sigtimedwait(&signals, nullptr, &timeout);
    if (signal > 0) return signal;
    if (watchdog) sd_notify(0, "WATCHDOG=1");
  }
}

void RunDaemon(const DaemonCommandOptions& o, const sigset_t& signals) {
  acquisition::CaptureDaemonOptions daemon_options;
  daemon_options.state_dir = o.state;
  daemon_options.fault_retry_interval = std::chrono::milliseconds(static_cast<std::int64_t>(o.fault_retry_s * 1000));
  daemon_options.prompt_operator = o.prompt_operator;
  std::unique_ptr<acquisition::CaptureStation> station;
  if (pipelines::DrivesRealDevices(sim::LoadRig(o.station.rig))) {
    // A person does the operator steps of a real rig: they are always asked.
    station = std::make_unique<pipelines::RigStation>(pipelines::RigStationOptions{o.station.rig, o.calibration});
    daemon_options.prompt_operator = true;
    spdlog::info("rig {} open (its devices; calibration {})", station->rig_name(), o.calibration.string());
  } else {
    if (!o.calibration.empty()) {
      throw core::Error("--calibration " + o.calibration.string() + ": rig " + o.station.rig +
                        " is simulated and uses its true calibration; --calibration is for a real rig");
    }
    auto simulated = std::make_unique<pipelines::SimulatedStation>(o.station);
    spdlog::info("rig {} open (simulated, scene {})", simulated->rig_name(), simulated->scene_name());
    station = std::move(simulated);
  }
  acquisition::CaptureDaemon daemon(std::move(station), daemon_options);
  acquisition::ControlServerOptions server_options;
  server_options.socket = o.socket.empty() ? o.state / "control.sock" : o.socket;
  // Made or checked only now that the daemon holds the state directory's lock.
  const fs::path token_file = o.state / "control.token", port_file = o.state / "control.port";
  std::error_code ec;
  fs::remove(port_file, ec);  // a killed daemon's; clients find no port while none listens
  const fs::path url_file = o.state / "control.url";
  fs::remove(url_file, ec);
  if (o.rotate_token) {
    acquisition::RotateBearerTokenFile(token_file);
    spdlog::info("a new bearer token is in {}", token_file.string());
  }
  if (o.tcp_port) {
    server_options.tcp_port = *o.tcp_port;
    server_options.bearer_token = acquisition::OpenOrCreateBearerTokenFile(token_file);
  }
  acquisition::ControlServer server(daemon, server_options);
  daemon.Start();
  spdlog::info("serving the control API on {}", server_options.socket.string());
  if (o.tcp_port) {
    core::WriteTextFileAtomically(port_file, std::to_string(server.tcp_port()) + "\n");
    spdlog::info("serving the control API on 127.0.0.1:{} (bearer token in {})", server.tcp_port(),
                 token_file.string());
    // The address carries the token: it goes to a file only this user may
    // read, never to the log, which others (the journal's readers) may.
    acquisition::WriteSecretFile(url_file, "http://127.0.0.1:" + std::to_string(server.tcp_port()) +
                                               "/#token=" + server_options.bearer_token + "\n");
    spdlog::info("status page: its address (with the token) is in {}", url_file.string());
  }
  sd_notify(0, "READY=1");
  const int signal = WaitForStop(signals);
  spdlog::info("{}: finishing the running step", strsignal(signal));
  sd_notify(0, "STOPPING=1");
  server.Stop();
  fs::remove(port_file, ec);
  fs::remove(url_file, ec);
  daemon.Stop();
  spdlog::info("stopped");
}

}  // namespace

int main(int argc, char** argv) {
  // Before any thread: what the daemon writes under its state folder is
  // 0750/0640 whatever umask it was started under (files made 0600, the
  // token's, stay so). The control socket's mode is set by chmod, not this.
  ::umask(027);
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  CLI::App app{"mesocapd: the capture session daemon (runs a queue of captures on one rig)"};
  app.set_version_flag("--version", std::string("mesocapd ") + core::Version());
  int verbose = 0, quiet = 0;
  app.add_flag("-v,--verbose", verbose, "more log output (-vv for trace)");
  app.add_flag("-q,--quiet", quiet, "only warnings and errors in the log");
  DaemonCommandOptions o;
  app.add_option("--state", o.state, "state directory: the job queue and every job's capture session")->required();
  app.add_option("--socket", o.socket, "control socket (default: STATE/control.sock)");
  int tcp_port = 0;
  CLI::Option* tcp_option =
      app.add_option("--tcp-port", tcp_port,
                     "also serve the API and the status page on 127.0.0.1 at this port (0: any free port; "
                     "written to STATE/control.port), with the bearer token in STATE/control.token")
          ->check(CLI::Range(0, 65535));
  app.add_option("--rig", o.station.rig,
                 "shipped rig (tiny, small, paper) or a rig description file; one that drives real devices "
                 "(Tic stages, GPIO lamps and laser, Aravis cameras) is opened as it is, the others are simulated")
      ->capture_default_str();
  app.add_option("--calibration", o.calibration,
                 "a real rig's calibration (mesocap calibrate --session): written into each session, used for "
                 "the sweeps analysed as they arrive");
  AddSceneOptions(&app, &o.station.scene);
  app.add_option("--seed", o.station.seed, "seed of the simulated sensor noise")->capture_default_str();
  app.add_flag("--no-noise", o.station.no_noise, "no shot or read noise");
  app.add_option("--faults", o.station.faults, "fault plan file (mesocap.faults) added to the rig's own faults");
  app.add_flag("--serve-cameras", o.station.serve_cameras,
               "serve the simulated cameras as GigE Vision devices on loopback and drive them through Aravis");
  app.add_flag("--prompt-operator", o.prompt_operator,
               "pause at each operator step (plates, laser mounts, board tilts) until a client acknowledges it "
               "(mesocap capture ack); without it the simulated operator acts at once");
  app.add_flag("--rotate-token", o.rotate_token,
               "replace STATE/control.token with a new bearer token before serving (clients of the old one are "
               "refused; the status page's new address is in STATE/control.url)");
  app.add_option("--fault-retry-s", o.fault_retry_s, "seconds before a job paused on a fault is tried again")
      ->check(CLI::Range(0.0, 86400.0))
      ->capture_default_str();
  try {
    app.parse(argc, argv);
    if (*tcp_option) o.tcp_port = static_cast<std::uint16_t>(tcp_port);
    core::ConfigureLogging(verbose - quiet);
    RunDaemon(o, signals);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    std::fprintf(core::MessageStream(), "mesocapd: error: %s\n",
                 core::Cut(e.what(), 4 * core::kMaxEchoedCharacters).c_str());
    return 1;
  }
  return 0;
}
