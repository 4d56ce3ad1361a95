// The capture daemon's job records against a careless operator: a new job
// never takes over the session of a job whose record was removed, ids grow
// past 999999 in number order, a finished job can be forgotten through the
// API, and the state folders' modes do not depend on the umask.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <nlohmann/json.hpp>

#include "acquisition/capture_daemon.h"
#include "acquisition/control_api.h"
#include "tests/acquisition/simulated_daemon.h"

namespace mesocap::acquisition {
namespace {

std::vector<std::string> Ids(const CaptureDaemon& daemon) {
  std::vector<std::string> ids;
  for (const CaptureJob& job : daemon.Jobs()) ids.push_back(job.id);
  return ids;
}

TEST(JobIdTest, MoreDigitsPast999999AndOneIdPerNumber) {
  EXPECT_EQ(JobId(1), "job-000001");
  EXPECT_EQ(JobId(999999), "job-999999");
  EXPECT_EQ(JobId(1000000), "job-1000000");
  for (const char* id : {"job-000001", "job-999999", "job-1000000", "job-18446744073"}) {
    EXPECT_TRUE(IsJobId(id)) << id;
    EXPECT_EQ(JobId(JobNumber(id)), id);
  }
  for (const char* id : {"job-00001", "job-0000001", "job-01000000", "job-12345a", "job-99999999999999999999"}) {
    EXPECT_FALSE(IsJobId(id)) << id;
  }
  EXPECT_TRUE(JobIdOrder()("job-999999", "job-1000000"));
  EXPECT_FALSE(JobIdOrder()("job-1000000", "job-999999"));
}

TEST_F(SimulatedDaemonTest, IdsGrowPast999999AndStayInNumberOrder) {
  fs::create_directories(state_ / "state" / "jobs");
  CaptureJob old;
  old.id = "job-999999";
  old.plan_kind = "capture";
  old.state = JobState::kDone;
  old.started = true;
  old.submitted_at = "2026-12-01T00:00:00Z";
  WriteCaptureJob(state_ / "state" / "jobs" / "job-999999.json", old);
  auto daemon = MakeDaemon();  // not started: nothing runs
  EXPECT_EQ(daemon->Submit("capture").id, "job-1000000");
  EXPECT_EQ(daemon->Submit("capture").id, "job-1000001");
  const std::vector<std::string> expected = {"job-999999", "job-1000000", "job-1000001"};
  EXPECT_EQ(Ids(*daemon), expected);
  EXPECT_EQ(ReadCaptureJob(state_ / "state" / "jobs" / "job-999999.json").state, JobState::kDone);
  daemon.reset();
  daemon = MakeDaemon();  // read back from disk in the same order
  EXPECT_EQ(Ids(*daemon), expected);
  EXPECT_EQ(daemon->Submit("capture").id, "job-1000002");
}

TEST_F(SimulatedDaemonTest, AfterItsRecordsAreRemovedANewJobCapturesAFreshSession) {
  auto daemon = MakeDaemon();
  const std::string first = daemon->Submit("capture").id;
  daemon->Start();
  WaitFor(*daemon, first, JobState::kDone);
  daemon.reset();
  for (const fs::directory_entry& entry : fs::directory_iterator(state_ / "state" / "jobs")) fs::remove(entry.path());
  daemon = MakeDaemon();
  const std::string second = daemon->Submit("capture").id;
  EXPECT_EQ(second, "job-000002");  // sessions/job-000001 keeps its number
  daemon->Start();
  const CaptureJob done = WaitFor(*daemon, second, JobState::kDone);
  EXPECT_EQ(done.frames, capture_frames_);
  EXPECT_EQ(SessionDifferences(*daemon, second, "capture"), "");
  EXPECT_EQ(SessionDifferences(*daemon, first, "capture"), "");
}

TEST_F(SimulatedDaemonTest, AJobThatNeverRanRefusesAFolderInItsSessionsPlace) {
  auto daemon = MakeDaemon();
  const fs::path stranger = state_ / "state" / "sessions" / "job-000001";
  fs::create_directories(stranger);  // made after the daemon counted the sessions
  std::ofstream(stranger / "notes.txt") << "an operator's\n";
  const std::string id = daemon->Submit("capture").id;
  ASSERT_EQ(id, "job-000001");
  daemon->Start();
  const CaptureJob failed = WaitFor(*daemon, id, JobState::kFailed);
  EXPECT_EQ(failed.error, "sessions/job-000001 exists and belongs to no job: move it away");
  std::vector<std::string> left;
  for (const fs::directory_entry& entry : fs::directory_iterator(stranger)) left.push_back(entry.path().filename());
  EXPECT_EQ(left, std::vector<std::string>{"notes.txt"});
}

ControlResponse Delete(CaptureDaemon& daemon, const std::string& path, const std::string& query = "") {
  ControlRequest request;
  request.method = "DELETE";
  request.path = path;
  request.query = query;
  return HandleControlRequest(daemon, request);
}

std::string ErrorIn(const ControlResponse& r) { return nlohmann::json::parse(r.body).value("error", ""); }

TEST_F(SimulatedDaemonTest, AFinishedJobIsForgottenWithOrWithoutItsSession) {
  auto daemon = MakeDaemon();
  const std::string id = daemon->Submit("capture").id;
  ControlResponse r = Delete(*daemon, "/v1/jobs/" + id);
  EXPECT_EQ(r.status, 409);
  EXPECT_EQ(ErrorIn(r), "job job-000001 is queued: cannot forget it");
  daemon->Start();
  WaitFor(*daemon, id, JobState::kDone);
  r = Delete(*daemon, "/v1/jobs/" + id, "delete_session=2");
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(ErrorIn(r), "query delete_session: expected 0 or 1, got 2");
  r = Delete(*daemon, "/v1/jobs/" + id);
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(nlohmann::json::parse(r.body), (nlohmann::json{{"forgotten", id}, {"session", "kept"}}));
  EXPECT_FALSE(daemon->Job(id));
  EXPECT_FALSE(fs::exists(state_ / "state" / "jobs" / (id + ".json")));
  EXPECT_EQ(SessionDifferences(*daemon, id, "capture"), "");
  EXPECT_EQ(Delete(*daemon, "/v1/jobs/" + id).status, 404);

  const std::string next = daemon->Submit("capture").id;
  EXPECT_EQ(next, "job-000002");
  WaitFor(*daemon, next, JobState::kDone);
  r = Delete(*daemon, "/v1/jobs/" + next, "delete_session=1");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(nlohmann::json::parse(r.body).at("session"), "deleted");
  EXPECT_FALSE(fs::exists(daemon->SessionDir(next)));
  EXPECT_TRUE(daemon->Jobs().empty());
  daemon.reset();
  EXPECT_TRUE(MakeDaemon()->Jobs().empty());  // forgotten on disk too
}

unsigned PermissionBits(const fs::path& path) {
  struct stat st {};
  ::lstat(path.c_str(), &st);
  return st.st_mode & 07777;
}

// What the daemon's core makes itself; mesocapd's test checks every file of
// a capture (the process's umask is mesocapd's to set).
TEST_F(SimulatedDaemonTest, TheStateFoldersAre0750AndTheLock0640WhateverTheUmask) {
  for (const mode_t mask : {mode_t{022}, mode_t{077}}) {
    fs::remove_all(state_ / "state");
    const mode_t old = ::umask(mask);
    auto daemon = MakeDaemon();
    ::umask(old);
    for (const char* folder : {"", "jobs", "sessions"}) {
      EXPECT_EQ(PermissionBits(state_ / "state" / folder), 0750u) << folder << " under umask 0" << std::oct << mask;
    }
    EXPECT_EQ(PermissionBits(state_ / "state" / "mesocapd.lock"), 0640u) << "under umask 0" << std::oct << mask;
  }
}

}  // namespace
}  // namespace mesocap::acquisition
