// The status page in a real browser: headless Chromium loads it from a
// capture daemon's loopback port (the token in the address's fragment) while
// a capture runs on the simulated tiny rig, one step at a time as the test
// lets it. The page shows the running job's steps as the API reports them,
// and the same page, without a reload, shows more when more steps are done;
// a page with a wrong token says it was refused. Skipped only where
// /usr/bin/chromium is absent; no process, socket or file is left.
#include <gtest/gtest.h>

#include <condition_variable>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>

#include "acquisition/capture_daemon.h"
#include "acquisition/control_server.h"
#include "pipelines/simulated_station.h"
#include "tests/acquisition/headless_chromium.h"
#include "tests/common/no_leftovers.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The simulated station, held after each journaled step until the test
// allows the next: the job stays "running" at a known step for as long as
// the browser needs.
class SteppedStation : public CaptureStation {
 public:
  explicit SteppedStation(std::unique_ptr<CaptureStation> station) : station_(std::move(station)) {}

  std::string rig_name() const override { return station_->rig_name(); }
  std::vector<std::string> camera_ids() const override { return station_->camera_ids(); }
  std::vector<drivers::DeviceState> DeviceStates() override { return station_->DeviceStates(); }
  void OpenSession(const fs::path& dir, const std::string& plan_kind) override {
    station_->OpenSession(dir, plan_kind);
  }
  CaptureRunReport RunSession(const fs::path& dir, CaptureRunnerOptions options,
                              const CaptureStepDone& step_done) override {
    return station_->RunSession(dir, options, [&](const CaptureRunReport& report, std::size_t journaled) {
      step_done(report, journaled);
      std::unique_lock lock(mutex_);
      allowed_.wait(lock, [&] { return released_ || steps_allowed_ > 0; });
      if (!released_) --steps_allowed_;
    });
  }

  // Lets `steps` more steps run after the one the station waits after.
  void Allow(int steps) {
    {
      std::lock_guard lock(mutex_);
      steps_allowed_ += steps;
    }
    allowed_.notify_all();
  }
  // Lets every step run (the daemon is stopping).
  void Release() {
    {
      std::lock_guard lock(mutex_);
      released_ = true;
    }
    allowed_.notify_all();
  }

 private:
  std::unique_ptr<CaptureStation> station_;
  std::mutex mutex_;
  std::condition_variable allowed_;
  int steps_allowed_ = 0;
  bool released_ = false;
};

const std::string kToken = "5f0c1d2e3a4b5c6d7e8f90a1b2c3d4e5f60718293a4b5c6d7e8f90a1b2c3d4e5";

// Chromium's files in the shared-memory and temporary folders ("org.chromium"
// in their names), which a killed browser could leave behind.
std::set<std::string> ChromiumLeftovers() {
  std::set<std::string> out;
  for (const char* dir : {"/dev/shm", "/tmp"}) {
    std::error_code ec;
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      if (entry.path().filename().string().find("org.chromium") != std::string::npos) out.insert(entry.path());
    }
  }
  return out;
}

class StatusPageBrowserTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(testing::kChromium)) GTEST_SKIP() << testing::kChromium << " is not installed";
    leftovers_before_ = ChromiumLeftovers();
    pipelines::SimulatedStationOptions station_options;
    station_options.rig = "tiny";
    station_options.seed = 7;
    auto station = std::make_unique<SteppedStation>(std::make_unique<pipelines::SimulatedStation>(station_options));
    station_ = station.get();
    CaptureDaemonOptions daemon_options;
    daemon_options.state_dir = dir_ / "state";
    daemon_ = std::make_unique<CaptureDaemon>(std::move(station), daemon_options);
    ControlServerOptions server_options;
    server_options.socket = dir_ / "control.sock";
    server_options.tcp_port = 0;
    server_options.bearer_token = kToken;
    server_ = std::make_unique<ControlServer>(*daemon_, server_options);
    address_ = "http://127.0.0.1:" + std::to_string(server_->tcp_port()) + "/";
  }
  void TearDown() override {
    if (!daemon_) return;
    station_->Release();
    server_->Stop();
    daemon_->Stop();
    EXPECT_EQ(ChromiumLeftovers(), leftovers_before_);
  }

  // The job as the API reports it.
  CaptureJob WaitForSteps(const std::string& id, std::size_t steps) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(600);
    while (std::chrono::steady_clock::now() < deadline) {
      const CaptureJob job = *daemon_->Job(id);
      if (job.steps_done >= steps) return job;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ADD_FAILURE() << id << " never reached " << steps << " steps";
    return *daemon_->Job(id);
  }

  testing::TemporaryDirectory dir_;
  SteppedStation* station_ = nullptr;
  std::unique_ptr<CaptureDaemon> daemon_;
  std::unique_ptr<ControlServer> server_;
  std::string address_;
  std::set<std::string> leftovers_before_;
};

// What the page's row of `id` shows: "STATE STEPS_TEXT BAR_VALUE/BAR_MAX".
std::string RowExpression(const std::string& id) {
  return "(() => { const row = document.getElementById('job-" + id +
         "'); if (!row) return ''; const bar = row.querySelector('progress');"
         " return row.querySelector('.state').textContent + ' ' + row.querySelector('.steps').textContent + ' ' +"
         " bar.value + '/' + bar.max; })()";
}

std::string Shown(const CaptureJob& job) {
  const std::string steps = std::to_string(job.steps_done) + "/" + std::to_string(job.steps_total);
  return std::string(ToString(job.state)) + " " + steps + " " + steps;
}

TEST_F(StatusPageBrowserTest, ThePageShowsTheRunningJobsStepsAndFollowsThem) {
  const std::string id = daemon_->Submit("capture").id;
  daemon_->Start();
  const CaptureJob first = WaitForSteps(id, 1);  // held after its first step
  ASSERT_EQ(first.state, JobState::kRunning);
  ASSERT_GE(first.steps_total, 5u);

  testing::HeadlessChromium browser(address_ + "#token=" + kToken);
  ASSERT_TRUE(browser.attached());
  const std::string row = RowExpression(id);
  json shown = browser.EvaluateUntil(row, [&](const json& v) { return v == Shown(first); });
  EXPECT_EQ(shown, Shown(first)) << browser.log();
  EXPECT_EQ(browser.Evaluate("document.title"), "mesocapd status");
  EXPECT_EQ(browser.Evaluate("document.getElementById('rig').textContent"), "\u2014 rig tiny, worker running");
  // An ETA once a step has run ("0m01s"), and the log's lines.
  const json eta = browser.Evaluate("document.querySelector('#job-" + id + " .eta').textContent");
  EXPECT_TRUE(eta.is_string() && eta.get<std::string>().find('m') != std::string::npos) << eta;
  const json log = browser.Evaluate("document.getElementById('log').textContent");
  EXPECT_TRUE(log.is_string() && log.get<std::string>().find(id + " running") != std::string::npos) << log;
  // Each device's state as /v1/rig reports it.
  const json devices = browser.Evaluate("document.getElementById('devices').textContent");
  ASSERT_TRUE(devices.is_string()) << devices;
  for (const char* line : {"camera cam0: ", "turntable: at 0 deg, homed", "lamps: 2 lamps", "laser unit: "}) {
    EXPECT_NE(devices.get<std::string>().find(line), std::string::npos) << line << " in " << devices;
  }
  EXPECT_EQ(browser.Evaluate("document.getElementById('connection').className"), "");

  // Three more steps; the same page (no reload: a mark set on it stays)
  // follows them.
  browser.Evaluate("window.markedBeforeTheSteps = 1");
  station_->Allow(3);
  const CaptureJob later = WaitForSteps(id, first.steps_done + 3);
  ASSERT_EQ(later.steps_done, first.steps_done + 3);
  ASSERT_EQ(later.state, JobState::kRunning);
  shown = browser.EvaluateUntil(row, [&](const json& v) { return v == Shown(later); });
  EXPECT_EQ(shown, Shown(later)) << browser.log();
  EXPECT_EQ(browser.Evaluate("window.markedBeforeTheSteps"), 1);
  browser.Close();
}

// Members this daemon does not report yet (a rig's "devices", a job's
// "operator_prompt", camera previews) as the page shows them when present:
// its own functions fed such records, in one synchronous evaluation (the
// next poll would replace what they drew).
TEST_F(StatusPageBrowserTest, ThePageShowsDeviceStatesPromptsAndPreviewsWhenReported) {
  testing::HeadlessChromium browser(address_ + "#token=" + kToken);
  ASSERT_TRUE(browser.attached());
  browser.EvaluateUntil("document.body.dataset.polls", [](const json& v) { return v.is_string(); });
  EXPECT_EQ(browser.Evaluate(R"((() => {
    showDevices([{device: 'camera cam0', kind: 'camera', ok: true, state: 'grabbing'},
                 {device: 'turntable', kind: 'stage', ok: false, state: 'stalled at 12.5 deg'}]);
    const items = [...document.querySelectorAll('#devices li')];
    return items.map((li) => li.firstChild.className + ' ' + li.textContent).join('; ');
  })())"),
            "state-ok camera cam0: grabbing; state-bad turntable: stalled at 12.5 deg");
  EXPECT_EQ(browser.Evaluate(R"((() => {
    const row = jobRow({id: 'job-000007', plan: 'calibration', state: 'paused', steps_done: 3, steps_total: 9,
                        eta_s: null, frames: 12, dropped_frames: 0, retries: 1,
                        pause_reason: 'waiting for the operator', operator_prompt: 'Place the checkerboard', error: ''});
    return row.querySelector('.prompt').textContent + ' | ' + row.querySelector('.steps').textContent;
  })())"),
            "waiting for the operator: Place the checkerboard | 3/9");
  // A camera without a preview endpoint (or without a frame yet): said so.
  const json previews = browser.Evaluate(R"((async () => {
    await showPreviews([{device: 'camera cam0', kind: 'camera', ok: true, state: 'idle'}]);
    return document.getElementById('previews').textContent;
  })())");
  EXPECT_EQ(previews, "cam0no frame yet");
  browser.Close();
}

TEST_F(StatusPageBrowserTest, APageWithAWrongTokenSaysItWasRefused) {
  testing::HeadlessChromium browser(address_ + "#token=" + std::string(64, '0'));
  ASSERT_TRUE(browser.attached());
  const std::string expression = "document.getElementById('connection').textContent";
  const std::string refused = "refused: wrong bearer token: use the one in mesocapd's control.token";
  EXPECT_EQ(browser.EvaluateUntil(expression, [&](const json& v) { return v == refused; }), refused) << browser.log();
  EXPECT_EQ(browser.Evaluate("document.getElementById('jobs').children.length"), 0);
  browser.Close();
}

}  // namespace
}  // namespace mesocap::acquisition

// After every test: no Chromium process and no socket left open.
::testing::Environment* const kNoLeftovers = ::testing::AddGlobalTestEnvironment(new mesocap::testing::NoLeftovers());
