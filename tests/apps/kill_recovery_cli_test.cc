// kill -9 at seeded random moments of simulate, process mdf, process btf and
// compress: the next run (simulate --resume, the others with --replace)
// completes, its output equals an uninterrupted run's byte for byte apart
// from timestamps and timings, and no temporary is left. The moments are
// uniform over the uninterrupted run's duration. MESOCAP_KILL_TRIALS sets the
// trials per command (default 2, 1 in the sanitize preset, whose runs are
// ten times slower; docs/BENCHMARKS.md reports a run of 10).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/common/child_process.h"
#include "tests/common/killed_writer.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/normalized_tree.h"
#include "tests/common/temporary_directory.h"
#include "tests/common/trial_count.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;
using testing::Differences;
using testing::Normalized;

pid_t Start(const std::vector<std::string>& args) { return testing::StartProcess(MESOCAP_BINARY, args); }
int Wait(pid_t pid) { return testing::WaitForExit(pid); }

// Seconds an uninterrupted run takes.
double Timed(const std::vector<std::string>& args) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(Wait(Start(args)), 0);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int Trials() { return testing::TrialCount("MESOCAP_KILL_TRIALS", 2); }

struct Job {
  std::string name;
  // The command writing `out`, and the one that completes it after a kill.
  std::vector<std::string> (*run)(const fs::path& inputs, const fs::path& out);
  std::vector<std::string> (*rerun)(const fs::path& inputs, const fs::path& out);
};

std::vector<std::string> Simulate(const fs::path&, const fs::path& out) {
  return {"-q", "simulate", "--rig", "tiny", "--seed", "4", "--out", out.string()};
}
std::vector<std::string> SimulateResume(const fs::path& in, const fs::path& out) {
  auto args = Simulate(in, out);
  args.push_back("--resume");
  return args;
}
std::vector<std::string> ProcessMdf(const fs::path& in, const fs::path& out) {
  return {"-q", "process", "mdf", "--session", (in / "S").string(), "--out", out.string()};
}
// One representation (not the budget's choice among ten): what a kill leaves
// behind does not depend on it, and each run stays one SVD long.
std::vector<std::string> ProcessBtf(const fs::path& in, const fs::path& out) {
  return {"-q",       "process", "btf",     "--session", (in / "S").string(), "--out", out.string(),
          "--layout", "paper",   "--color", "rgb"};
}
std::vector<std::string> Compress(const fs::path& in, const fs::path& out) {
  return {"-q", "compress", "--in", (in / "T").string(), "--out", out.string(), "--layout", "paper", "--color", "rgb"};
}
template <std::vector<std::string> (*F)(const fs::path&, const fs::path&)>
std::vector<std::string> Replacing(const fs::path& in, const fs::path& out) {
  auto args = F(in, out);
  args.push_back("--replace");
  return args;
}

class KillRecoveryTest : public ::testing::TestWithParam<Job> {
 protected:
  static void SetUpTestSuite() {
    inputs_ = new testing::TemporaryDirectory();
    ASSERT_EQ(Wait(Start(Simulate({}, *inputs_ / "S"))), 0);
    ASSERT_EQ(
        Wait(Start({"-q", "groundtruth", "--rig", "tiny", "--texture-size", "16", "--out", (*inputs_ / "T").string()})),
        0);
  }
  static void TearDownTestSuite() { delete inputs_; }
  static testing::TemporaryDirectory* inputs_;
};

testing::TemporaryDirectory* KillRecoveryTest::inputs_ = nullptr;

TEST_P(KillRecoveryTest, NextRunCompletesBitIdenticalWithNoTemporaryLeft) {
  const Job& job = GetParam();
  testing::TemporaryDirectory work;
  // The same output name everywhere: a package is named after its folder.
  const fs::path reference = work / "reference" / "out";
  fs::create_directories(reference.parent_path());
  const double seconds = Timed(job.run(inputs_->path(), reference));
  const auto expected = Normalized(reference);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> moment(0.0, seconds);
  for (int trial = 0; trial < Trials(); ++trial) {
    const double at = moment(rng);
    SCOPED_TRACE("killed after " + std::to_string(at) + " s of " + std::to_string(seconds));
    const fs::path out = work / ("trial" + std::to_string(trial)) / "out";
    fs::create_directories(out.parent_path());
    const pid_t pid = Start(job.run(inputs_->path(), out));
    std::this_thread::sleep_for(std::chrono::duration<double>(at));
    ::kill(pid, SIGKILL);
    Wait(pid);
    // A kill before the command made its output folder left nothing to
    // complete: the next run is the command itself (simulate --resume
    // refuses a session that does not exist, by design).
    const bool started = fs::exists(out);
    ASSERT_EQ(Wait(Start(started ? job.rerun(inputs_->path(), out) : job.run(inputs_->path(), out))), 0);
    EXPECT_EQ(Differences(Normalized(out), expected), "");
    EXPECT_EQ(testing::CountTemporaries(work.path()), 0);
    fs::remove_all(out);
  }
}

INSTANTIATE_TEST_SUITE_P(Jobs, KillRecoveryTest,
                         ::testing::Values(Job{"simulate", Simulate, SimulateResume},
                                           Job{"process_mdf", ProcessMdf, Replacing<ProcessMdf>},
                                           Job{"process_btf", ProcessBtf, Replacing<ProcessBtf>},
                                           Job{"compress", Compress, Replacing<Compress>}),
                         [](const auto& info) { return info.param.name; });

}  // namespace
}  // namespace mesocap
