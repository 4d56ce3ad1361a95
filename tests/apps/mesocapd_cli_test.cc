// mesocapd and `mesocap capture` as a user runs them, on the tiny rig: a
// capture submitted to the daemon records the session `mesocap simulate`
// records; kill -9 of the daemon at seeded random moments, then a restart,
// completes every session byte-identical (but for times) with its frames
// counted once; SIGTERM finishes the step and exits 0; one client watching
// while another pauses and resumes sees a consistent job; over loopback TCP
// the client steers the daemon with the token file, and bad address flags
// get clear errors. MESOCAP_KILL_TRIALS sets the kill trials (default 3;
// docs/BENCHMARKS.md reports a run of 50), MESOCAP_DAEMON_RIG the rig
// (default tiny). Built twice: with the simulated cameras in process, and
// served over GigE Vision on loopback (MESOCAPD_SERVE_CAMERAS, run in
// scripts/in-network-namespace.sh).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "tests/common/child_process.h"
#include "tests/common/file_bytes.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/normalized_tree.h"
#include "tests/common/temporary_directory.h"
#include "tests/common/trial_count.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::Mesocap;

std::string Rig() {
  const char* env = std::getenv("MESOCAP_DAEMON_RIG");
  return env && *env ? env : "tiny";
}

// The options of the rig that mesocapd and simulate share.
std::vector<std::string> RigArguments() {
  std::vector<std::string> args{"--rig", Rig(), "--seed", "4"};
#ifdef MESOCAPD_SERVE_CAMERAS
  args.push_back("--serve-cameras");
#endif
  return args;
}

std::string Joined(const std::vector<std::string>& args) {
  std::string line;
  for (const std::string& a : args) line += " " + a;
  return line;
}

class Daemon {
 public:
  explicit Daemon(const fs::path& state, const std::vector<std::string>& options = {"-q"}) : state_(state) {
    std::vector<std::string> args = RigArguments();
    args.push_back("--state");
    args.push_back(state.string());
    args.insert(args.end(), options.begin(), options.end());
    pid_ = testing::StartProcess(MESOCAPD_BINARY, args, log());
    // Ready when it answers (building the rig takes a moment).
    for (int i = 0; i < 6000; ++i) {
      if (Client("list").exit_code == 0) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    ADD_FAILURE() << "mesocapd did not answer on " << socket();
  }
  ~Daemon() {
    if (pid_ > 0) Kill(SIGKILL);
  }
  int Kill(int signal) {
    ::kill(pid_, signal);
    const int code = testing::WaitForExit(pid_);
    pid_ = -1;
    return code;
  }
  std::string socket() const { return (state_ / "control.sock").string(); }
  fs::path log() const { return state_.parent_path() / "daemon.log"; }
  testing::CommandResult Client(const std::string& args) const {
    return Mesocap("capture " + args + " --socket " + socket());
  }
  json Job(const std::string& id) const { return json::parse(Client("status " + id + " --json").out); }

 private:
  fs::path state_;
  pid_t pid_ = -1;
};

int Trials() { return testing::TrialCount("MESOCAP_KILL_TRIALS", 3); }

class MesocapdTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TemporaryDirectory();
    ASSERT_EQ(Mesocap("-q simulate" + Joined(RigArguments()) + " --out " + (*dir_ / "reference").string()).exit_code,
              0);
    reference_ = new std::map<std::string, std::string>(testing::Normalized(*dir_ / "reference"));
  }
  static void TearDownTestSuite() {
    delete reference_;
    delete dir_;
  }
  std::string Differences(const fs::path& state, const std::string& id) {
    return testing::Differences(testing::Normalized(state / "sessions" / id), *reference_);
  }
  // Submits the session to `daemon` and watches it to its end; the first
  // uninterrupted run keeps the time that took and the frames the job
  // counted, for the kill trials.
  struct Uninterrupted {
    double seconds = 0;
    json frames;
  };
  static void SubmitAndWatch(const Daemon& daemon, testing::CommandResult* submitted, testing::CommandResult* watched) {
    const auto start = std::chrono::steady_clock::now();
    *submitted = daemon.Client("submit");
    *watched = daemon.Client("watch job-000001");
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!uninterrupted_ && submitted->exit_code == 0 && watched->exit_code == 0) {
      uninterrupted_ = Uninterrupted{seconds, daemon.Job("job-000001").at("frames")};
    }
  }
  static testing::TemporaryDirectory* dir_;
  static std::map<std::string, std::string>* reference_;
  // The first uninterrupted session of this run, whichever test recorded it.
  static std::optional<Uninterrupted> uninterrupted_;
  testing::TemporaryDirectory work_;
};

testing::TemporaryDirectory* MesocapdTest::dir_ = nullptr;
std::map<std::string, std::string>* MesocapdTest::reference_ = nullptr;
std::optional<MesocapdTest::Uninterrupted> MesocapdTest::uninterrupted_;

TEST_F(MesocapdTest, ASubmittedCaptureRecordsTheSessionSimulateRecords) {
  const fs::path state = work_ / "state";
  Daemon daemon(state);
  testing::CommandResult submitted, watched;
  SubmitAndWatch(daemon, &submitted, &watched);
  ASSERT_EQ(submitted.exit_code, 0) << submitted.err;
  EXPECT_EQ(submitted.out, "job-000001\n");
  EXPECT_EQ(watched.exit_code, 0) << watched.err;
  EXPECT_EQ(Differences(state, "job-000001"), "");
  const json job = daemon.Job("job-000001");
  if (Rig() == "tiny") {
    EXPECT_NE(watched.out.find("job-000001 done (capture) 34/34 steps"), std::string::npos) << watched.out;
    EXPECT_EQ(job.at("frames"), 1580);
  }
  EXPECT_EQ(job.at("dropped_frames"), 0);
  // Errors come back with the daemon's message and a non-zero exit.
  const testing::CommandResult missing = daemon.Client("status job-000009");
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("mesocapd: no job \"job-000009\""), std::string::npos) << missing.err;
  const testing::CommandResult done = daemon.Client("pause job-000001");
  EXPECT_NE(done.err.find("job job-000001 is done: cannot pause it"), std::string::npos) << done.err;
  EXPECT_EQ(daemon.Kill(SIGTERM), 0);
  EXPECT_FALSE(fs::exists(daemon.socket()));
  // No daemon: the client names the socket.
  const testing::CommandResult gone = daemon.Client("list");
  EXPECT_EQ(gone.exit_code, 1);
  EXPECT_NE(gone.err.find("cannot reach mesocapd at " + daemon.socket()), std::string::npos) << gone.err;
}

TEST_F(MesocapdTest, SigtermFinishesTheStepAndARestartResumes) {
  const fs::path state = work_ / "state";
  {
    Daemon daemon(state);
    ASSERT_EQ(daemon.Client("submit").exit_code, 0);
    while (daemon.Job("job-000001").at("steps_done") < 3) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    EXPECT_EQ(daemon.Kill(SIGTERM), 0);
  }
  Daemon daemon(state);
  const json resumed = daemon.Job("job-000001");
  EXPECT_GE(resumed.at("steps_done"), 3);
  EXPECT_EQ(daemon.Client("watch job-000001").exit_code, 0);
  EXPECT_EQ(Differences(state, "job-000001"), "");
  if (Rig() == "tiny") {
    EXPECT_EQ(daemon.Job("job-000001").at("frames"), 1580);
  }
}

TEST_F(MesocapdTest, KillAtARandomMomentThenRestartCompletesTheSameSession) {
  // How long the capture takes in the daemon, to draw moments from, and the
  // frames of an uninterrupted run: the first test's session, or one of its
  // own when it runs alone.
  if (!uninterrupted_) {
    const fs::path state = work_ / "timed";
    Daemon daemon(state);
    testing::CommandResult submitted, watched;
    SubmitAndWatch(daemon, &submitted, &watched);
    ASSERT_EQ(submitted.exit_code, 0) << submitted.err;
    ASSERT_EQ(watched.exit_code, 0) << watched.err;
    ASSERT_EQ(Differences(state, "job-000001"), "");
  }
  ASSERT_TRUE(uninterrupted_.has_value());
  const double seconds = uninterrupted_->seconds;
  const json frames = uninterrupted_->frames;
  if (Rig() == "tiny") {
    EXPECT_EQ(frames, 1580);
  }
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> moment(0.0, seconds);
  for (int trial = 0; trial < Trials(); ++trial) {
    const double at = moment(rng);
    SCOPED_TRACE("killed " + std::to_string(at) + " s after the submit, of " + std::to_string(seconds));
    const fs::path state = work_ / ("trial" + std::to_string(trial));
    {
      Daemon daemon(state);
      ASSERT_EQ(daemon.Client("submit").exit_code, 0);
      std::this_thread::sleep_for(std::chrono::duration<double>(at));
      daemon.Kill(SIGKILL);
    }
    Daemon daemon(state);
    const testing::CommandResult watched = daemon.Client("watch job-000001");
    ASSERT_EQ(watched.exit_code, 0) << watched.err;
    EXPECT_EQ(Differences(state, "job-000001"), "");
    // Every frame of the session counted once: none lost, none twice.
    EXPECT_EQ(daemon.Job("job-000001").at("frames"), frames);
    daemon.Kill(SIGTERM);
    fs::remove_all(state);
  }
}

TEST_F(MesocapdTest, OneClientWatchesWhileAnotherPausesAndResumes) {
  const fs::path state = work_ / "state";
  Daemon daemon(state);
  ASSERT_EQ(daemon.Client("submit").exit_code, 0);
  testing::CommandResult watched;
  std::thread watcher([&] { watched = daemon.Client("watch job-000001"); });
  while (daemon.Job("job-000001").at("steps_done") < 2) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(daemon.Client("pause job-000001").exit_code, 0);
  json job;
  for (int i = 0; i < 6000 && (job = daemon.Job("job-000001")).at("state") != "paused"; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ASSERT_EQ(job.at("state"), "paused");
  const auto steps = job.at("steps_done").get<int>();
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(daemon.Job("job-000001").at("steps_done"), steps);  // nothing runs while paused
  EXPECT_EQ(daemon.Client("resume job-000001").exit_code, 0);
  watcher.join();
  EXPECT_EQ(watched.exit_code, 0) << watched.err;
  // The watcher saw the pause, then the end.
  const std::size_t paused = watched.out.find("paused: paused by a client");
  EXPECT_NE(paused, std::string::npos) << watched.out;
  EXPECT_GT(watched.out.find("job-000001 done"), paused) << watched.out;
  EXPECT_EQ(Differences(state, "job-000001"), "");
}

TEST_F(MesocapdTest, OverLoopbackTcpTheClientSteersTheDaemonWithTheTokenFile) {
  const fs::path state = work_ / "state";
  const fs::path token_file = state / "control.token", port_file = state / "control.port";
  std::string token;
  {
    Daemon daemon(state, {"--tcp-port", "0"});
    EXPECT_EQ(fs::status(token_file).permissions() & fs::perms::all, fs::perms::owner_read | fs::perms::owner_write);
    token = testing::Slurp(token_file);
    ASSERT_EQ(token.size(), 65u);
    ASSERT_EQ(token.back(), '\n');
    token.pop_back();
    EXPECT_EQ(token.find_first_not_of("0123456789abcdef"), std::string::npos) << token;
    const std::string port = testing::Slurp(port_file);
    ASSERT_FALSE(port.empty());
    EXPECT_EQ(port.back(), '\n');
    const int number = std::atoi(port.c_str());
    ASSERT_GT(number, 0);
    ASSERT_LE(number, 65535);
    const std::string url = "http://127.0.0.1:" + std::to_string(number);
    const std::string over_tcp = " --url " + url + " --token-file " + token_file.string();

    const testing::CommandResult submitted = Mesocap("capture submit" + over_tcp);
    ASSERT_EQ(submitted.exit_code, 0) << submitted.err;
    EXPECT_EQ(submitted.out, "job-000001\n");
    const testing::CommandResult watched = Mesocap("capture watch job-000001" + over_tcp);
    EXPECT_EQ(watched.exit_code, 0) << watched.err;
    EXPECT_NE(watched.out.find("job-000001 done (capture) 34/34 steps"), std::string::npos) << watched.out;
    EXPECT_EQ(Differences(state, "job-000001"), "");
    // The daemon logged (at info level) the port, never the token: the
    // status page's address, the token in its fragment, is in a file only
    // the daemon's user may read.
    const std::string log = testing::Slurp(daemon.log());
    EXPECT_NE(log.find("serving the control API on 127.0.0.1:" + std::to_string(number)), std::string::npos) << log;
    EXPECT_NE(log.find("status page: its address (with the token) is in " + (state / "control.url").string()),
              std::string::npos)
        << log;
    EXPECT_EQ(log.find(token), std::string::npos) << log;
    EXPECT_EQ(testing::Slurp(state / "control.url"), url + "/#token=" + token + "\n");
    EXPECT_EQ(fs::status(state / "control.url").permissions() & fs::perms::all,
              fs::perms::owner_read | fs::perms::owner_write);

    // Another token: refused with the daemon's message.
    std::ofstream(work_ / "wrong.token") << std::string(64, '0') << "\n";
    const testing::CommandResult wrong =
        Mesocap("capture list --url " + url + " --token-file " + (work_ / "wrong.token").string());
    EXPECT_EQ(wrong.exit_code, 1);
    EXPECT_NE(wrong.err.find("mesocapd: wrong bearer token: use the one in mesocapd's control.token"),
              std::string::npos)
        << wrong.err;
    EXPECT_EQ(daemon.Kill(SIGTERM), 0);
    EXPECT_FALSE(fs::exists(port_file));  // no port or address while none listens
    EXPECT_FALSE(fs::exists(state / "control.url"));
    const testing::CommandResult gone = Mesocap("capture list" + over_tcp);
    EXPECT_EQ(gone.exit_code, 1);
    EXPECT_NE(gone.err.find("cannot reach mesocapd at " + url + ": "), std::string::npos) << gone.err;
  }
  {
    // A restart reuses the token.
    Daemon daemon(state, {"-q", "--tcp-port", "0"});
    EXPECT_EQ(testing::Slurp(token_file), token + "\n");
    EXPECT_EQ(daemon.Kill(SIGTERM), 0);
  }
  {
    // --rotate-token makes a new one; the old one is refused.
    fs::copy_file(token_file, work_ / "old.token");
    Daemon daemon(state, {"--tcp-port", "0", "--rotate-token"});
    const std::string rotated = testing::Slurp(token_file);
    EXPECT_NE(rotated, token + "\n");
    EXPECT_EQ(rotated.size(), 65u);
    EXPECT_EQ(fs::status(token_file).permissions() & fs::perms::all, fs::perms::owner_read | fs::perms::owner_write);
    const std::string url = "http://127.0.0.1:" + std::to_string(std::atoi(testing::Slurp(port_file).c_str()));
    const testing::CommandResult old =
        Mesocap("capture list --url " + url + " --token-file " + (work_ / "old.token").string());
    EXPECT_EQ(old.exit_code, 1);
    EXPECT_NE(old.err.find("mesocapd: wrong bearer token"), std::string::npos) << old.err;
    EXPECT_EQ(Mesocap("capture list --url " + url + " --token-file " + token_file.string()).exit_code, 0);
    EXPECT_EQ(testing::Slurp(state / "control.url"), url + "/#token=" + rotated);
    const std::string log = testing::Slurp(daemon.log());
    EXPECT_EQ(log.find(rotated.substr(0, 64)), std::string::npos) << log;
    EXPECT_EQ(daemon.Kill(SIGTERM), 0);
  }
  // A token file others may read is refused, by name.
  fs::permissions(token_file, fs::perms::group_read | fs::perms::others_read, fs::perm_options::add);
  const fs::path log = work_ / "refused.log";
  const pid_t pid = testing::StartProcess(MESOCAPD_BINARY,
                                          {"-q", "--rig", "tiny", "--state", state.string(), "--tcp-port", "0"}, log);
  EXPECT_EQ(testing::WaitForExit(pid), 1);
  EXPECT_EQ(testing::Slurp(log), "mesocapd: error: " + token_file.string() +
                                     ": mode 0644, expected 0600 (only mesocapd's user may read the bearer token); "
                                     "remove it and mesocapd makes a new one\n");
}

// Every folder 0750 and every file 0640 under the state folder (but the
// token, 0600), whatever the umask mesocapd was started under.
std::vector<std::string> WrongModes(const fs::path& state) {
  std::vector<std::string> wrong;
  const auto check = [&](const fs::path& path) {
    const fs::file_status status = fs::symlink_status(path);
    const fs::perms expected =
        fs::is_directory(status) ? fs::perms(0750) : fs::perms(path.filename() == "control.token" ? 0600 : 0640);
    if ((status.permissions() & fs::perms::all) != expected) wrong.push_back(path.string());
  };
  check(state);
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(state)) check(entry.path());
  return wrong;
}

TEST_F(MesocapdTest, TheStateFolderIs0750And0640WhateverTheUmask) {
  for (const mode_t mask : {mode_t{022}, mode_t{077}}) {
    const fs::path state = work_ / ("state-" + std::to_string(mask));
    const mode_t old = ::umask(mask);
    Daemon daemon(state, {"-q", "--tcp-port", "0"});
    ::umask(old);
    EXPECT_EQ(fs::status(daemon.socket()).permissions() & fs::perms::all, fs::perms(0660));
    EXPECT_EQ(daemon.Client("submit").exit_code, 0);
    EXPECT_EQ(daemon.Client("watch job-000001").exit_code, 0);
    EXPECT_EQ(daemon.Kill(SIGTERM), 0);
    EXPECT_EQ(WrongModes(state), std::vector<std::string>{}) << "umask 0" << std::oct << mask;
  }
}

TEST_F(MesocapdTest, ForgetRemovesAFinishedJobAndKeepsItsSessionUnlessAsked) {
  const fs::path state = work_ / "state";
  Daemon daemon(state);
  ASSERT_EQ(daemon.Client("submit").out, "job-000001\n");
  ASSERT_EQ(daemon.Client("watch job-000001").exit_code, 0);
  ASSERT_EQ(daemon.Client("submit").out, "job-000002\n");
  ASSERT_EQ(daemon.Client("watch job-000002").exit_code, 0);
  testing::CommandResult r = daemon.Client("forget job-000001");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "job-000001 forgotten; its session stays in STATE/sessions/job-000001\n");
  EXPECT_EQ(Differences(state, "job-000001"), "");
  r = daemon.Client("forget job-000002 --delete-session");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out, "job-000002 forgotten; its session deleted\n");
  EXPECT_FALSE(fs::exists(state / "sessions" / "job-000002"));
  EXPECT_EQ(daemon.Client("list").out, "no jobs\n");
  r = daemon.Client("forget job-000001");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("mesocapd: no job \"job-000001\""), std::string::npos) << r.err;
  // The kept session keeps its number: the next job is not job-000001.
  ASSERT_EQ(daemon.Client("submit").out, "job-000003\n");
}

TEST_F(MesocapdTest, BadAddressFlagsGetClearErrors) {
  const fs::path token_file = work_ / "control.token";
  std::ofstream(token_file) << std::string(64, 'a') << "\n";
  const std::string token = " --token-file " + token_file.string();
  const auto expect = [](const std::string& args, const std::string& message) {
    const testing::CommandResult r = Mesocap(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.err.find(message), std::string::npos) << args << "\n" << r.err;
  };
  const std::string loopback_only =
      "--url: expected http://127.0.0.1:PORT (mesocapd listens on loopback only; its port is in STATE/control.port), "
      "got ";
  expect("capture list --url http://0.0.0.0:8080" + token, loopback_only + "\"http://0.0.0.0:8080\"");
  expect("capture list --url https://127.0.0.1:8080" + token, loopback_only + "\"https://127.0.0.1:8080\"");
  expect("capture list --url http://127.0.0.1:99999" + token, loopback_only + "\"http://127.0.0.1:99999\"");
  expect("capture status job-000001 --url http://127.0.0.1:" + token, loopback_only + "\"http://127.0.0.1:\"");
  expect("capture list --url http://127.0.0.1:8080", "--url requires --token-file");
  expect("capture watch job-000001" + token, "--token-file requires --url");
  expect("capture list --url http://127.0.0.1:8080 --socket /tmp/x.sock" + token, "--socket excludes --url");
  std::ofstream(work_ / "short.token") << "abc\n";
  expect("capture list --url http://127.0.0.1:8080 --token-file " + (work_ / "short.token").string(),
         "--token-file: " + (work_ / "short.token").string() +
             ": expected a bearer token (64 lowercase hex digits and a newline, as mesocapd writes it)");
  // The daemon's port: a number up to 65535; no option names an address.
  const fs::path log = work_ / "mesocapd.log";
  for (const char* bad : {"70000", "-1", "http"}) {
    const pid_t pid =
        testing::StartProcess(MESOCAPD_BINARY, {"--state", (work_ / "state").string(), "--tcp-port", bad}, log);
    EXPECT_NE(testing::WaitForExit(pid), 0) << bad;
  }
  const std::string refused = testing::Slurp(log);
  EXPECT_NE(refused.find("--tcp-port: Value 70000 not in range 0 to 65535"), std::string::npos) << refused;
  EXPECT_FALSE(fs::exists(work_ / "state" / "control.token"));
}

}  // namespace
}  // namespace mesocap
