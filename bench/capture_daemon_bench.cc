// The capture daemon's overhead, on simulated rigs whose cameras are served
// as GigE Vision devices on loopback and driven through the Aravis backend:
// frames per second of one capture session run by the station alone
// (OpenSession + RunSession), through a CaptureDaemon with its ControlServer
// (submission to done), and through both while client threads poll
// GET /v1/jobs/ID and GET /v1/rig on the Unix socket, as fast as they can
// and at a UI's rate, with each request's latency. Modes are interleaved run
// by run, so a machine that slows down slows every mode. Every session is
// compared with a reference session of the station alone, recorded before
// the timed runs (files equal but for times): a fast but wrong run shows.
// Served cameras take port 3956 of 127.0.0.N, so run it in a network
// namespace of its own:
//   scripts/in-network-namespace.sh build/release/bench/mesocap_capture_daemon_bench --json out.json
#include <curl/curl.h>
#include <sys/resource.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "acquisition/capture_daemon.h"
#include "acquisition/control_server.h"
#include "apps/mesocap/control_client.h"
#include "core/error.h"
#include "core/logging.h"
#include "pipelines/simulated_station.h"
#include "tests/common/normalized_tree.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr const char* kOnePosition = "-one-position";

enum class Mode { kDirect, kDaemon, kPollingFlatOut, kPollingAtRate };
// The daemon's modes by their flag names. The station alone always runs:
// it is what the others are measured against.
const std::map<std::string, Mode> kDaemonModes = {
    {"daemon", Mode::kDaemon}, {"flat-out", Mode::kPollingFlatOut}, {"at-rate", Mode::kPollingAtRate}};

struct BenchOptions {
  // A shipped rig, whole ("tiny") or cut to one turntable angle, one arc
  // angle and one laser location ("small-one-position").
  std::vector<std::string> rigs = {"tiny"};
  std::vector<std::string> modes = {"daemon", "flat-out", "at-rate"};
  int runs = 3;
  int clients = 4;
  double poll_hz = 20;  // the polling mode "at a rate"; the other polls flat out
  std::uint64_t seed = 7;
  int samples_per_pixel_side = 3;  // the simulated cameras' rays per pixel side
  fs::path json_out;

  std::string Check() const {
    for (const std::string& rig : rigs) {
      std::string shipped = rig;
      if (shipped.size() > std::strlen(kOnePosition) && shipped.ends_with(kOnePosition)) {
        shipped.resize(shipped.size() - std::strlen(kOnePosition));
      }
      if (shipped != "tiny" && shipped != "small" && shipped != "paper") {
        return "--rig " + rig + ": expected tiny, small or paper, whole or cut (e.g. small-one-position)";
      }
    }
    for (const std::string& mode : modes) {
      if (!kDaemonModes.count(mode)) return "--modes " + mode + ": expected daemon, flat-out or at-rate";
    }
    if (samples_per_pixel_side < 1 || samples_per_pixel_side > 16) return "--samples-per-pixel-side must be 1..16";
    if (runs < 1) return "--runs must be at least 1";
    if (clients < 1 || clients > 32) return "--clients must be 1..32 (the server takes 64 connections)";
    if (!(poll_hz > 0 && poll_hz <= 1000)) return "--poll-hz must be in (0, 1000]";
    // Checked before the runs, not after them.
    const fs::path json_dir = json_out.has_parent_path() ? json_out.parent_path() : fs::path(".");
    if (!json_out.empty() && !fs::is_directory(json_dir)) {
      return "--json " + json_out.string() + ": " + json_dir.string() + " is not a directory";
    }
    return {};
  }
};

std::string ModeName(Mode mode, const BenchOptions& o) {
  switch (mode) {
    case Mode::kDirect:
      return "station alone";
    case Mode::kDaemon:
      return "daemon";
    case Mode::kPollingFlatOut:
      return "daemon, " + std::to_string(o.clients) + " clients flat out";
    case Mode::kPollingAtRate: {
      char text[64];
      std::snprintf(text, sizeof text, "daemon, %d clients at %g Hz", o.clients, o.poll_hz);
      return text;
    }
  }
  return {};
}

struct RunResult {
  double wall_s = 0;
  double cpu_s = 0;  // the whole process: station, Aravis, daemon, server, clients
  std::uint64_t frames = 0, dropped = 0, retries = 0;
  std::vector<double> latencies_ms;
  std::uint64_t failed_requests = 0;
  std::string last_request_error;
  std::string differences;  // files unlike the reference session's; empty when equal
  std::string failure;      // why the session did not complete; empty when it did
};

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

RunResult RunDirect(const pipelines::SimulatedStationOptions& station_options,
                    const acquisition::CaptureRunnerOptions& run, const fs::path& session) {
  pipelines::SimulatedStation station(station_options);
  RunResult r;
  const double cpu0 = CpuSeconds();
  const Clock::time_point t0 = Clock::now();
  station.OpenSession(session, "capture");
  const acquisition::CaptureRunReport report = station.RunSession(session, run, {});
  r.wall_s = Seconds(Clock::now() - t0);
  r.cpu_s = CpuSeconds() - cpu0;
  r.frames = report.frames;
  r.dropped = report.dropped_frames;
  r.retries = report.retries;
  return r;
}

struct ClientRecord {
  std::vector<double> latencies_ms;
  std::uint64_t failed = 0;
  std::string last_error;
};

// One client: alternately the job's record and the rig's status, each
// request on a connection of its own (as `mesocap capture status` makes
// them); every `period` when it is not zero, else back to back.
void Poll(const fs::path& socket, const std::string& id, Clock::duration period, const std::atomic<bool>& stop,
          ClientRecord* out) {
  const ControlClient client(ControlEndpoint{socket, "", ""});
  Clock::time_point next = Clock::now();
  for (std::uint64_t i = 0; !stop; ++i) {
    if (period.count() > 0) {
      std::this_thread::sleep_until(next);
      next += period;
      if (stop) break;
    }
    const Clock::time_point t0 = Clock::now();
    try {
      client.Get(i % 2 == 0 ? "/v1/jobs/" + id : "/v1/rig");
      out->latencies_ms.push_back(1e3 * Seconds(Clock::now() - t0));
    } catch (const std::exception& e) {
      ++out->failed;
      out->last_error = e.what();
    }
  }
}

RunResult RunThroughDaemon(const pipelines::SimulatedStationOptions& station_options,
                           const acquisition::CaptureRunnerOptions& run, const fs::path& state, int clients,
                           Clock::duration period, const fs::path& reference) {
  acquisition::CaptureDaemonOptions daemon_options;
  daemon_options.state_dir = state;
  daemon_options.runner = run;
  // A fault pause is a failed measurement here, never waited out.
  daemon_options.fault_retry_interval = std::chrono::hours(1);
  acquisition::CaptureDaemon daemon(std::make_unique<pipelines::SimulatedStation>(station_options), daemon_options);
  acquisition::ControlServerOptions server_options;
  server_options.socket = state / "control.sock";
  acquisition::ControlServer server(daemon, server_options);
  daemon.Start();

  RunResult r;
  std::uint64_t seen = daemon.events().last_number();
  const double cpu0 = CpuSeconds();
  const Clock::time_point t0 = Clock::now();
  const std::string id = daemon.Submit("capture").id;
  std::atomic<bool> stop{false};
  std::vector<ClientRecord> records(clients);
  std::vector<std::thread> threads;
  for (int i = 0; i < clients; ++i) {
    threads.emplace_back(Poll, server_options.socket, id, period, std::cref(stop), &records[i]);
  }
  // Woken by the daemon's own events, so the end is seen at once, without
  // adding a polling client of our own.
  acquisition::CaptureJob job;
  while (true) {
    for (const acquisition::DaemonEvent& e : daemon.events().After(seen, std::chrono::milliseconds(1000))) {
      seen = e.number;
    }
    job = *daemon.Job(id);
    if (acquisition::IsFinished(job.state) || job.state == acquisition::JobState::kPaused) break;
  }
  r.wall_s = Seconds(Clock::now() - t0);
  r.cpu_s = CpuSeconds() - cpu0;
  stop = true;
  for (std::thread& t : threads) t.join();
  server.Stop();
  daemon.Stop();
  if (job.state != acquisition::JobState::kDone) {
    throw core::Error("the daemon's job ended " + std::string(acquisition::ToString(job.state)) + ": " +
                      job.pause_reason + job.error);
  }
  r.frames = job.frames;
  r.dropped = job.dropped_frames;
  r.retries = job.retries;
  for (ClientRecord& record : records) {
    r.latencies_ms.insert(r.latencies_ms.end(), record.latencies_ms.begin(), record.latencies_ms.end());
    r.failed_requests += record.failed;
    if (!record.last_error.empty()) r.last_request_error = record.last_error;
  }
  r.differences = testing::Differences(testing::Normalized(daemon.SessionDir(id)), testing::Normalized(reference));
  return r;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Nearest rank: the smallest value with at least `q` of the values at or below it.
double Percentile(const std::vector<double>& sorted, double q) {
  if (sorted.empty()) return NAN;
  const std::size_t rank = static_cast<std::size_t>(std::ceil(q * sorted.size()));
  return sorted[std::max<std::size_t>(rank, 1) - 1];
}

std::string CpuModel() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown";
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

json RunJson(const RunResult& r) {
  if (!r.failure.empty()) return {{"failure", r.failure}};
  return {{"wall_s", r.wall_s},
          {"cpu_s", r.cpu_s},
          {"frames", r.frames},
          {"frames_per_s", r.frames / r.wall_s},
          {"dropped_frames", r.dropped},
          {"retries", r.retries},
          {"requests", r.latencies_ms.size()},
          {"failed_requests", r.failed_requests},
          {"last_request_error", r.last_request_error},
          {"session_equal", r.differences.empty()},
          {"differences", r.differences}};
}

// Prints the rig's table and returns its figures: per mode, over its
// completed sessions, the median frames/s, its ratio to the station alone
// (of the medians, and the median of the rounds' paired ratios: round i of a
// mode against round i alone, which ran next to it), the process's CPU, and
// the latency of every request of every run together; and how many sessions
// failed (a device stopped the capture).
json Summarize(const std::string& rig, std::uint64_t frames, const std::vector<Mode>& modes,
               const std::vector<std::vector<RunResult>>& results, const BenchOptions& o) {
  const auto fps = [](const RunResult& r) { return r.frames / r.wall_s; };
  std::vector<double> direct_fps;
  for (const RunResult& r : results[0]) {
    if (r.failure.empty()) direct_fps.push_back(fps(r));
  }
  const double direct = direct_fps.empty() ? NAN : Median(direct_fps);
  std::printf("\n%s (frames a session: %llu)\n", rig.c_str(), static_cast<unsigned long long>(frames));
  std::printf(
      "| mode | sessions done | median s | frames/s median (min-max) | ratio to alone (paired) "
      "| CPU cores busy | requests | latency ms p50 / p99 / max | failed requests | sessions equal |\n"
      "|---|---|---|---|---|---|---|---|---|---|\n");
  json figures = json::array();
  for (std::size_t m = 0; m < results.size(); ++m) {
    std::vector<double> wall, rate, paired, busy, latencies;
    std::uint64_t failed = 0;
    int equal = 0, done = 0;
    json runs = json::array();
    for (std::size_t i = 0; i < results[m].size(); ++i) {
      const RunResult& r = results[m][i];
      runs.push_back(RunJson(r));
      if (!r.failure.empty()) continue;
      ++done;
      wall.push_back(r.wall_s);
      rate.push_back(fps(r));
      if (results[0][i].failure.empty()) paired.push_back(fps(r) / fps(results[0][i]));
      busy.push_back(r.cpu_s / r.wall_s);
      latencies.insert(latencies.end(), r.latencies_ms.begin(), r.latencies_ms.end());
      failed += r.failed_requests;
      equal += r.differences.empty() ? 1 : 0;
    }
    const std::string name = ModeName(modes[m], o);
    json mode = {
        {"mode", name}, {"sessions_done", done}, {"sessions_failed", results[m].size() - done}, {"runs", runs}};
    if (done == 0) {
      std::printf("| %s | 0/%zu | - | - | - | - | - | - | - | - |\n", name.c_str(), results[m].size());
      figures.push_back(mode);
      continue;
    }
    std::sort(latencies.begin(), latencies.end());
    const double ratio = Median(rate) / direct;
    const double paired_ratio = paired.empty() ? NAN : Median(paired);
    std::printf("| %s | %d/%zu | %.2f | %.1f (%.1f-%.1f) | %.3f (%.3f) | %.2f | ", name.c_str(), done,
                results[m].size(), Median(wall), Median(rate), *std::min_element(rate.begin(), rate.end()),
                *std::max_element(rate.begin(), rate.end()), ratio, paired_ratio, Median(busy));
    if (latencies.empty()) {
      std::printf("0 | - | - | %d/%d |\n", equal, done);
    } else {
      std::printf("%zu | %.2f / %.2f / %.2f | %llu | %d/%d |\n", latencies.size(), Percentile(latencies, 0.5),
                  Percentile(latencies, 0.99), latencies.back(), static_cast<unsigned long long>(failed), equal, done);
    }
    mode.update({{"median_wall_s", Median(wall)},
                 {"median_frames_per_s", Median(rate)},
                 {"ratio_to_station_alone", ratio},
                 {"median_paired_ratio", paired_ratio},
                 {"meets_0_95", ratio >= 0.95},
                 {"median_cpu_cores_busy", Median(busy)},
                 {"requests", latencies.size()},
                 {"failed_requests", failed},
                 {"sessions_equal", equal}});
    if (!latencies.empty()) {
      mode["latency_ms"] = {
          {"p50", Percentile(latencies, 0.5)}, {"p99", Percentile(latencies, 0.99)}, {"max", latencies.back()}};
    }
    figures.push_back(mode);
  }
  std::fflush(stdout);
  return {{"rig", rig}, {"frames_per_session", frames}, {"modes", figures}};
}

int Run(const BenchOptions& o) {
  curl_global_init(CURL_GLOBAL_DEFAULT);  // before any client thread: it is not thread-safe
  const unsigned cores = std::thread::hardware_concurrency();
  std::printf("machine: %s, %u cores; load average at start %s\n", CpuModel().c_str(), cores, LoadAverage().c_str());
  std::printf(
      "%d runs a mode, modes interleaved; %d clients; seed %llu; %d x %d rays a pixel; times are submission "
      "(or OpenSession) to done\n\n",
      o.runs, o.clients, static_cast<unsigned long long>(o.seed), o.samples_per_pixel_side, o.samples_per_pixel_side);
  json out = {{"machine", {{"cpu", CpuModel()}, {"cores", cores}, {"load_average_start", LoadAverage()}}},
              {"runs", o.runs},
              {"clients", o.clients},
              {"poll_hz", o.poll_hz},
              {"seed", o.seed},
              {"samples_per_pixel_side", o.samples_per_pixel_side},
              {"rigs", json::array()}};
  acquisition::CaptureRunnerOptions run;
  run.show_progress = false;
  // A frame late on a loaded machine is waited for, not retaken with fresh
  // noise (which would make the session differ from the reference).
  run.frame_timeout = std::chrono::milliseconds(5000);
  std::vector<Mode> modes = {Mode::kDirect};
  for (const std::string& mode : o.modes) modes.push_back(kDaemonModes.at(mode));
  bool all_equal = true;
  for (const std::string& rig : o.rigs) {
    testing::TemporaryDirectory dir;
    pipelines::SimulatedStationOptions station;
    station.seed = o.seed;
    station.samples_per_pixel_side = o.samples_per_pixel_side;
    station.serve_cameras = true;
    station.rig = rig;
    if (rig.ends_with(kOnePosition)) {
      const std::string shipped = rig.substr(0, rig.size() - std::strlen(kOnePosition));
      station.rig = testing::WriteRig(dir / "rig.json", testing::OnePositionRig(shipped));
    }
    // The reference every session is compared with: a run of the station
    // alone before the timed ones (a device that stops it ends the bench).
    const fs::path reference = dir / "reference";
    const std::uint64_t frames = RunDirect(station, run, reference).frames;
    std::vector<std::vector<RunResult>> results(modes.size());
    int failures = 0;
    for (int run_index = 0; run_index < o.runs; ++run_index) {
      // Each round starts one mode later, so no mode always runs first
      // (after the last round's clean-up) or last.
      for (std::size_t k = 0; k < modes.size(); ++k) {
        const std::size_t m = (k + run_index) % modes.size();
        const Mode mode = modes[m];
        RunResult r;
        // A session a device stops (a served camera that sends no frame on a
        // loaded machine) is counted and shown, and leaves the medians.
        try {
          if (mode == Mode::kDirect) {
            r = RunDirect(station, run, dir / "direct");
            r.differences = testing::Differences(testing::Normalized(dir / "direct"), testing::Normalized(reference));
          } else {
            const Clock::duration period =
                mode == Mode::kPollingAtRate
                    ? std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / o.poll_hz))
                    : Clock::duration::zero();
            r = RunThroughDaemon(station, run, dir / "state", mode == Mode::kDaemon ? 0 : o.clients, period, reference);
          }
        } catch (const std::exception& e) {
          r = RunResult();
          r.failure = e.what();
          ++failures;
        }
        fs::remove_all(dir / "direct");
        fs::remove_all(dir / "state");
        results[m].push_back(r);
        if (!r.failure.empty()) {
          std::printf("  %s run %d, %s: FAILED: %s\n", rig.c_str(), run_index + 1, ModeName(mode, o).c_str(),
                      r.failure.c_str());
          std::fflush(stdout);
          continue;
        }
        all_equal = all_equal && r.differences.empty();
        std::printf("  %s run %d, %s: %.2f s, %llu frames, %.1f frames/s, %zu requests%s\n", rig.c_str(), run_index + 1,
                    ModeName(mode, o).c_str(), r.wall_s, static_cast<unsigned long long>(r.frames), r.frames / r.wall_s,
                    r.latencies_ms.size(), r.differences.empty() ? "" : (", SESSION DIFFERS:" + r.differences).c_str());
        std::fflush(stdout);
      }
    }
    out["rigs"].push_back(Summarize(rig, frames, modes, results, o));
    out["rigs"].back()["sessions_failed"] = failures;
  }
  out["machine"]["load_average_end"] = LoadAverage();
  std::printf("load average at the end %s\n", LoadAverage().c_str());
  if (!o.json_out.empty()) {
    std::ofstream file(o.json_out);
    file << out.dump(2) << "\n";
    if (!file) throw core::Error(o.json_out.string() + ": cannot write");
  }
  if (!all_equal) std::printf("\nSOME SESSIONS DIFFER from the reference: the figures above are not valid\n");
  return all_equal ? 0 : 1;
}

}  // namespace
}  // namespace mesocap

int main(int argc, char** argv) {
  CLI::App app{
      "mesocap_capture_daemon_bench: frames/s through the capture daemon against the station alone, "
      "and API latency while clients poll (run it in scripts/in-network-namespace.sh)"};
  mesocap::BenchOptions o;
  app.add_option("--rig", o.rigs, "tiny, small or paper, whole or cut to one position (small-one-position); repeatable")
      ->capture_default_str();
  app.add_option("--runs", o.runs, "runs of each mode (the figure is their median)")->capture_default_str();
  app.add_option("--modes", o.modes,
                 "the daemon's modes to run besides the station alone: daemon (no client), flat-out (clients "
                 "back to back), at-rate (each client at --poll-hz)")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--clients", o.clients, "polling client threads")->capture_default_str();
  app.add_option("--poll-hz", o.poll_hz, "each client's rate in the at-a-rate mode")->capture_default_str();
  app.add_option("--seed", o.seed, "the simulated sensor's noise seed")->capture_default_str();
  app.add_option("--samples-per-pixel-side", o.samples_per_pixel_side, "the simulated cameras' rays per pixel side")
      ->capture_default_str();
  int verbose = 0;
  app.add_flag("-v,--verbose", verbose, "the station's and the daemon's log on stderr (-vv for debug)");
  app.add_option("--json", o.json_out, "also write the figures and every run as JSON to this file");
  CLI11_PARSE(app, argc, argv);
  if (const std::string problem = o.Check(); !problem.empty()) {
    std::fprintf(stderr, "mesocap_capture_daemon_bench: %s\n", problem.c_str());
    return 2;
  }
  mesocap::core::ConfigureLogging(verbose - 1);
  try {
    return mesocap::Run(o);
  } catch (const std::exception& e) {
    std::fprintf(mesocap::core::MessageStream(), "mesocap_capture_daemon_bench: error: %s\n", e.what());
    return 1;
  }
}
