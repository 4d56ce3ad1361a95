#include "formats/capture_session.h"

#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <random>

#include "core/error.h"
#include "core/version.h"
#include "formats/capture_journal.h"
#include "formats/captured_session.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::formats {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void Spit(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary | std::ios::trunc) << text; }

void AppendText(const fs::path& p, const std::string& text) {
  std::ofstream(p, std::ios::binary | std::ios::app) << text;
}

SessionManifest ExampleManifest() {
  SessionManifest m;
  m.software_version = "0.1.0-test";
  m.created_utc = "2025-06-01T12:34:56.789Z";
  m.rig = {{"name", "bench rig A"},
           {"cameras", {{{"id", "cam0"}, {"model", "Dragonfly"}, {"exposure_ms", 12.5}}}},
           {"notes", nullptr}};
  m.calibration = "calibration/rig.json";
  m.calibration_checksum = core::FileChecksum{12, 0x0123456789abcdef};
  m.plan.push_back(
      {"btf-t000-a000-l0", StepKind::kBtfImage, {{"turntable_deg", 0}, {"arc_deg", 0}, {"lamp", "halogen0"}}});
  m.plan.push_back({"laser-cal-m0", StepKind::kLaserCalibration, json::object()});
  m.plan.push_back(
      {"sweep-t000-m0", StepKind::kLaserSweep, {{"mount", "mount0"}, {"tilt_deg", {-20, 20}}, {"frames", 400}}});
  m.plan.push_back({"dark-frame", StepKind::kOther, {{"note", "lens cap on"}}});
  return m;
}

void ExpectSame(const SessionManifest& a, const SessionManifest& b) {
  EXPECT_EQ(a.software_version, b.software_version);
  EXPECT_EQ(a.created_utc, b.created_utc);
  EXPECT_EQ(a.rig, b.rig);
  EXPECT_EQ(a.calibration, b.calibration);
  ASSERT_EQ(a.plan.size(), b.plan.size());
  for (std::size_t i = 0; i < a.plan.size(); ++i) {
    EXPECT_EQ(a.plan[i].id, b.plan[i].id);
    EXPECT_EQ(a.plan[i].kind, b.plan[i].kind);
    EXPECT_EQ(a.plan[i].params, b.plan[i].params);
  }
}

// The message of the Error `f` throws (type E or derived), naming `file`.
template <typename E = core::FormatError, typename F>
std::string ErrorOf(F&& f, const fs::path& file) {
  try {
    f();
  } catch (const E& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "wrong exception type: " << e.what();
    return {};
  }
  ADD_FAILURE() << "nothing thrown for " << file;
  return {};
}

// ---- manifest -------------------------------------------------------------

TEST(CaptureSession, CreateThenReadKeepsEveryField) {
  testing::TemporaryDirectory dir;
  const fs::path session = dir / "session";
  CreateCaptureSession(session, ExampleManifest());
  ExpectSame(ReadSessionManifest(session), ExampleManifest());
  const json j = json::parse(Slurp(session / kSessionManifestName));
  EXPECT_EQ(j["format"], "mesocap.session");
  EXPECT_EQ(j["version"], 2);
  EXPECT_EQ(j["calibration"]["xxh3_64"], "0123456789abcdef");
  EXPECT_EQ(j["plan"]["steps"][2]["frames"], 400);  // params sit beside id and kind
  EXPECT_EQ(j["plan"]["steps"][2]["kind"], "laser_sweep");
}

TEST(CaptureSession, CreateFillsVersionAndTime) {
  testing::TemporaryDirectory dir;
  SessionManifest m = ExampleManifest();
  m.software_version.clear();
  m.created_utc.clear();
  m.calibration.reset();
  CreateCaptureSession(dir / "s", m);
  const SessionManifest read = ReadSessionManifest(dir / "s");
  EXPECT_EQ(read.software_version, core::Version());
  EXPECT_TRUE(IsUtcTimestamp(read.created_utc)) << read.created_utc;
  EXPECT_FALSE(read.calibration.has_value());
}

TEST(CaptureSession, CreateRefusesAFolderThatHoldsAnything) {
  testing::TemporaryDirectory dir;
  fs::create_directories(dir / "empty");
  CreateCaptureSession(dir / "empty", ExampleManifest());  // an empty folder is fine

  fs::create_directories(dir / "used");
  Spit(dir / "used" / "keep.txt", "precious");
  EXPECT_THROW(CreateCaptureSession(dir / "used", ExampleManifest()), core::Error);
  EXPECT_EQ(Slurp(dir / "used" / "keep.txt"), "precious");
  EXPECT_FALSE(fs::exists(dir / "used" / kSessionManifestName));

  const std::string before = Slurp(dir / "empty" / kSessionManifestName);
  SessionManifest other = ExampleManifest();
  other.rig["name"] = "another rig";
  EXPECT_THROW(CreateCaptureSession(dir / "empty", other), core::Error);  // an existing session
  EXPECT_EQ(Slurp(dir / "empty" / kSessionManifestName), before);

  Spit(dir / "file", "x");
  EXPECT_THROW(CreateCaptureSession(dir / "file", ExampleManifest()), core::Error);
}

TEST(CaptureSession, InvalidManifestIsRefusedBeforeTouchingTheDisk) {
  testing::TemporaryDirectory dir;
  const std::vector<std::function<void(SessionManifest&)>> edits = {
      [](SessionManifest& m) { m.plan[1].id = m.plan[0].id; },
      [](SessionManifest& m) { m.plan[0].id = "a/b"; },
      [](SessionManifest& m) { m.rig.erase("name"); },
      [](SessionManifest& m) { m.rig = json::array(); },
      [](SessionManifest& m) { m.calibration = "../calibration.json"; },
      [](SessionManifest& m) { m.created_utc = "yesterday"; },
      [](SessionManifest& m) { m.plan[0].params["kind"] = "other"; },
      [](SessionManifest& m) { m.plan[0].params = 5; },
      [](SessionManifest& m) { m.rig["name"] = std::string("\xff\xfe", 2); },  // not UTF-8
  };
  for (std::size_t i = 0; i < edits.size(); ++i) {
    SCOPED_TRACE(i);
    SessionManifest m = ExampleManifest();
    edits[i](m);
    EXPECT_THROW(CreateCaptureSession(dir / "s", m), core::Error);
    EXPECT_FALSE(fs::exists(dir / "s" / kSessionManifestName));
  }
}

struct Edit {
  std::string what;
  std::function<void(json&)> apply;
  std::string field;
};

std::vector<Edit> HostileManifestEdits() {
  using P = json::json_pointer;
  const auto set = [](const std::string& pointer, json value) {
    return [pointer, value](json& j) { j[P(pointer)] = value; };
  };
  const auto erase = [](const std::string& parent, const std::string& key) {
    return [parent, key](json& j) { j[P(parent)].erase(key); };
  };
  json many_steps = json::array();
  for (std::size_t i = 0; i <= kMaxPlanSteps; ++i) many_steps.push_back(json::object());
  return {
      {"other format", set("/format", "mesocap.calibration"), "format"},
      {"version 3", set("/version", 3), "version"},
      {"version null", set("/version", nullptr), "version"},
      {"unknown member", set("/extra", true), "extra"},
      {"no software version", erase("", "software_version"), "software_version"},
      {"empty software version", set("/software_version", ""), "software_version"},
      {"numeric software version", set("/software_version", 1.0), "software_version"},
      {"bad time", set("/created_utc", "2025-06-01 12:34:56"), "created_utc"},
      {"no such day", set("/created_utc", "2025-02-29T00:00:00Z"), "created_utc"},
      {"local time", set("/created_utc", "2025-06-01T12:34:56+02:00"), "created_utc"},
      {"no rig", erase("", "rig"), "rig"},
      {"rig list", set("/rig", json::array()), "rig"},
      {"rig without name", erase("/rig", "name"), "rig.name"},
      {"rig name number", set("/rig/name", 42), "rig.name"},
      {"rig name empty", set("/rig/name", ""), "rig.name"},
      {"absolute calibration", set("/calibration/path", "/etc/calibration.json"), "calibration.path"},
      {"escaping calibration", set("/calibration/path", "a/../../b.json"), "calibration.path"},
      {"empty calibration", set("/calibration/path", ""), "calibration.path"},
      {"calibration null", set("/calibration", nullptr), "calibration"},
      {"calibration path only", set("/calibration", "calibration.json"), "calibration"},
      {"calibration without hash", erase("/calibration", "xxh3_64"), "calibration.xxh3_64"},
      {"calibration short hash", set("/calibration/xxh3_64", "0123"), "calibration.xxh3_64"},
      {"calibration upper-case hash", set("/calibration/xxh3_64", "0123456789ABCDEF"), "calibration.xxh3_64"},
      {"calibration negative size", set("/calibration/bytes", -1), "calibration.bytes"},
      {"calibration unknown member", set("/calibration/sha1", "x"), "calibration.sha1"},
      {"no plan", erase("", "plan"), "plan"},
      {"plan unknown member", set("/plan/order", "random"), "plan.order"},
      {"steps not list", set("/plan/steps", json::object()), "plan.steps"},
      {"too many steps", set("/plan/steps", many_steps), "plan.steps"},
      {"step not object", set("/plan/steps/1", "laser-cal-m0"), "plan.steps[1]"},
      {"duplicate step", set("/plan/steps/3/id", "laser-cal-m0"), "plan.steps[3].id"},
      {"step id with space", set("/plan/steps/0/id", "btf 0"), "plan.steps[0].id"},
      {"step id number", set("/plan/steps/0/id", 0), "plan.steps[0].id"},
      {"no step id", erase("/plan/steps/2", "id"), "plan.steps[2].id"},
      {"unknown kind", set("/plan/steps/0/kind", "dance"), "plan.steps[0].kind"},
      {"no kind", erase("/plan/steps/0", "kind"), "plan.steps[0].kind"},
  };
}

TEST(CaptureSession, HostileManifestEditsNameFileAndField) {
  testing::TemporaryDirectory dir;
  CreateCaptureSession(dir / "s", ExampleManifest());
  const fs::path file = dir / "s" / kSessionManifestName;
  const json valid = json::parse(Slurp(file));
  for (const auto& edit : HostileManifestEdits()) {
    SCOPED_TRACE(edit.what);
    json j = valid;
    edit.apply(j);
    Spit(file, j.dump(1));
    const std::string message = ErrorOf([&] { ReadSessionManifest(dir / "s"); }, file);
    EXPECT_NE(message.find("'" + edit.field + "'"), std::string::npos) << message;
  }
}

TEST(CaptureSession, DeepRigAndOversizeManifestAreRejected) {
  testing::TemporaryDirectory dir;
  CreateCaptureSession(dir / "s", ExampleManifest());
  const fs::path file = dir / "s" / kSessionManifestName;
  json j = json::parse(Slurp(file));
  j["rig"]["deep"] = "DEEP";
  const std::string text = j.dump();
  for (const std::size_t depth : {70, 200000}) {
    const auto at = text.find("\"DEEP\"");
    std::string deep = text;
    deep.replace(at, 6, std::string(depth, '[') + std::string(depth, ']'));
    Spit(file, deep);
    const auto message = ErrorOf([&] { ReadSessionManifest(dir / "s"); }, file);
    EXPECT_NE(message.find("nest deeper"), std::string::npos) << message;
  }
  std::string huge_number = text;
  huge_number.replace(huge_number.find("\"DEEP\""), 6, "1e400");
  Spit(file, huge_number);
  ErrorOf([&] { ReadSessionManifest(dir / "s"); }, file);
  std::string big = text;
  big.resize(kMaxSessionManifestBytes + 1, '\n');
  Spit(file, big);
  EXPECT_NE(ErrorOf([&] { ReadSessionManifest(dir / "s"); }, file).find("at most"), std::string::npos);
  fs::remove(file);
  EXPECT_NE(ErrorOf([&] { ReadSessionManifest(dir / "s"); }, file).find("not found"), std::string::npos);
}

TEST(CaptureSessionFuzz, TruncatedAndMutatedManifests) {
  testing::TemporaryDirectory dir;
  CreateCaptureSession(dir / "s", ExampleManifest());
  const fs::path file = dir / "s" / kSessionManifestName;
  const std::string text = Slurp(file);
  for (std::size_t n = 0; n + 1 < text.size(); ++n) {
    Spit(file, text.substr(0, n));
    ErrorOf([&] { ReadSessionManifest(dir / "s"); }, file);
  }
  std::mt19937 rng(42);
  std::uniform_int_distribution<std::size_t> offset(0, text.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  int rejected = 0;
  for (int i = 0; i < 1500; ++i) {
    std::string mutated = text;
    mutated[offset(rng)] = static_cast<char>(byte(rng));
    Spit(file, mutated);
    try {
      ReadSessionManifest(dir / "s");
    } catch (const core::Error& e) {
      ++rejected;
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a mesocap::Error: " << e.what();
    }
  }
  EXPECT_GT(rejected, 500);
}

TEST(CaptureSession, UtcTimestamps) {
  const auto t = std::chrono::sys_days{std::chrono::year{2025} / 6 / 1} + std::chrono::hours{12} +
                 std::chrono::minutes{34} + std::chrono::milliseconds{56789};
  EXPECT_EQ(UtcTimestamp(t), "2025-06-01T12:34:56.789Z");
  EXPECT_TRUE(IsUtcTimestamp(UtcTimestamp(std::chrono::system_clock::now())));
  EXPECT_TRUE(IsUtcTimestamp("2024-02-29T23:59:60Z"));
  EXPECT_TRUE(IsUtcTimestamp("2025-06-01T12:34:56.123456789Z"));
  for (const char* bad : {"", "Z", "2025-06-01", "2025-06-01T12:34:56", "2025-06-01T12:34:56z", "2025-13-01T00:00:00Z",
                          "2025-06-31T00:00:00Z", "2025-06-01T24:00:00Z", "2025-06-01T12:34:56.Z",
                          "2025-06-01T12:34:56.1234567890Z", "2025-06-01T12:34:5xZ", "+2025-06-01T12:34:56Z"}) {
    EXPECT_FALSE(IsUtcTimestamp(bad)) << bad;
  }
}

TEST(CaptureSession, SessionPathsStayInside) {
  for (const char* good : {"a", "images/cam0/000.exr", "a.b/c..d/...", "x-y_z"}) {
    EXPECT_TRUE(IsSessionPath(good)) << good;
  }
  for (const char* bad :
       {"", "/etc/passwd", "..", "../a", "a/..", "a/../b", "./a", "a/./b", "a//b", "a/", "a\\b", "a\nb"}) {
    EXPECT_FALSE(IsSessionPath(bad)) << bad;
  }
  EXPECT_FALSE(IsSessionPath(std::string("a\0b", 3)));
  EXPECT_FALSE(IsSessionPath(std::string(1025, 'a')));
}

// ---- journal --------------------------------------------------------------

// A session with data files for the example plan's first steps.
// ExampleManifest with every step of kind "other": a CapturedSession reads
// the steps of a rig's kinds against the session's rig, and the example's
// rig is no rig description.
SessionManifest ExampleManifestOfOtherSteps() {
  SessionManifest m = ExampleManifest();
  for (PlannedStep& step : m.plan) step.kind = StepKind::kOther;
  return m;
}

struct ExampleSession {
  testing::TemporaryDirectory dir;
  fs::path root = dir / "s";
  fs::path journal = root / kSessionJournalName;
  SessionManifest manifest = ExampleManifestOfOtherSteps();

  ExampleSession() {
    CreateCaptureSession(root, manifest);
    fs::create_directories(root / "btf");
    Spit(root / "btf" / "000.exr", std::string(1000, 'x'));
    Spit(root / "btf" / "001.exr", std::string(1234, 'y'));
    Spit(root / "laser.json", "{}");
  }
};

JournalRecord Record(std::uint64_t seq, std::string step, std::vector<JournalFile> files = {}) {
  return {seq, std::move(step), "2025-06-01T13:00:0" + std::to_string(seq % 10) + "Z", std::move(files), std::nullopt};
}

// A journaled file by size; the journal adds its hash.
JournalFile F(std::string path, std::uint64_t bytes) { return {std::move(path), bytes, std::nullopt}; }

void ExpectSameRecords(const std::vector<JournalRecord>& a, const std::vector<JournalRecord>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].seq, b[i].seq);
    EXPECT_EQ(a[i].step, b[i].step);
    EXPECT_EQ(a[i].time_utc, b[i].time_utc);
    ASSERT_EQ(a[i].files.size(), b[i].files.size());
    for (std::size_t k = 0; k < a[i].files.size(); ++k) {
      EXPECT_EQ(a[i].files[k].path, b[i].files[k].path);
      EXPECT_EQ(a[i].files[k].bytes, b[i].files[k].bytes);
    }
  }
}

std::vector<JournalRecord> ExampleRecords() {
  return {Record(0, "btf-t000-a000-l0", {F("btf/000.exr", 1000), F("btf/001.exr", 1234)}),
          Record(1, "laser-cal-m0", {F("laser.json", 2)}), Record(2, "dark-frame")};
}

TEST(CaptureJournal, AppendThenReadBack) {
  ExampleSession s;
  {
    CaptureJournal journal(s.journal, &s.manifest);
    EXPECT_EQ(journal.next_seq(), 0u);
    for (const auto& r : ExampleRecords()) journal.Append(r);
    EXPECT_TRUE(journal.IsDone("laser-cal-m0"));
    EXPECT_FALSE(journal.IsDone("sweep-t000-m0"));
  }
  const JournalContents read = ReadCaptureJournal(s.journal, &s.manifest);
  ExpectSameRecords(read.records, ExampleRecords());
  EXPECT_EQ(read.dropped_bytes, 0u);
  EXPECT_EQ(read.intact_bytes, fs::file_size(s.journal));
  // One JSON object per line.
  const std::string text = Slurp(s.journal);
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 3);
  EXPECT_EQ(json::parse(text.substr(0, text.find('\n')))["seq"], 0);

  // Reopening resumes where it stopped.
  CaptureJournal journal(s.journal, &s.manifest);
  EXPECT_EQ(journal.next_seq(), 3u);
  ExpectSameRecords(journal.records(), ExampleRecords());
  journal.Append(Record(3, "sweep-t000-m0"));
  EXPECT_EQ(ReadCaptureJournal(s.journal).records.size(), 4u);
}

TEST(CaptureJournal, AppendRefusesBadRecordsAndLeavesTheFileAsItWas) {
  ExampleSession s;
  CaptureJournal journal(s.journal, &s.manifest);
  journal.Append(ExampleRecords()[0]);
  const std::string before = Slurp(s.journal);
  const std::vector<JournalRecord> bad = {
      Record(0, "laser-cal-m0"),                                             // seq repeated
      Record(2, "laser-cal-m0"),                                             // seq skipped
      Record(1, "btf-t000-a000-l0"),                                         // step done already
      Record(1, "not-in-plan"),                                              // step outside the plan
      Record(1, "bad id"),                                                   // not an id
      {1, "laser-cal-m0", "13:00", {}, std::nullopt},                        // not a UTC time
      Record(1, "laser-cal-m0", {F("/etc/passwd", 100)}),                    // absolute
      Record(1, "laser-cal-m0", {F("../outside", 100)}),                     // escapes the session
      Record(1, "laser-cal-m0", {F("", 0)}),                                 // empty
      Record(1, "laser-cal-m0", {F("laser.json", 2), F("laser.json", 2)}),   // twice
      Record(1, "laser-cal-m0", {F("missing.exr", 10)}),                     // no such file
      Record(1, "laser-cal-m0", {F("laser.json", 3)}),                       // wrong size
      Record(1, "laser-cal-m0", {F("btf", 0)}),                              // a folder
      Record(1, "laser-cal-m0", {F("laser.json", std::uint64_t{1} << 63)}),  // absurd size
  };
  for (std::size_t i = 0; i < bad.size(); ++i) {
    SCOPED_TRACE(i);
    const std::string message = ErrorOf<core::Error>([&] { journal.Append(bad[i]); }, s.journal);
    EXPECT_EQ(Slurp(s.journal), before);
  }
  journal.Append(Record(1, "laser-cal-m0", {F("laser.json", 2)}));
  EXPECT_EQ(ReadCaptureJournal(s.journal, &s.manifest).records.size(), 2u);
}

TEST(CaptureJournal, OneWriterAtATime) {
  ExampleSession s;
  CaptureJournal first(s.journal);
  EXPECT_NE(ErrorOf<core::Error>([&] { CaptureJournal second(s.journal); }, s.journal).find("another"),
            std::string::npos);
}

TEST(CaptureJournal, TornTailIsDroppedAndTruncatedOnReopen) {
  ExampleSession s;
  {
    CaptureJournal journal(s.journal, &s.manifest);
    journal.Append(ExampleRecords()[0]);
    journal.Append(ExampleRecords()[1]);
  }
  const auto good_size = fs::file_size(s.journal);
  const std::string half = R"({"files":[],"seq":2,"step":"dark-fr)";
  AppendText(s.journal, half);  // a crash in the middle of an append

  const JournalContents read = ReadCaptureJournal(s.journal, &s.manifest);
  EXPECT_EQ(read.records.size(), 2u);
  EXPECT_EQ(read.dropped_bytes, half.size());
  EXPECT_EQ(read.intact_bytes, good_size);
  EXPECT_EQ(fs::file_size(s.journal), good_size + half.size());  // reading changes nothing

  {
    CaptureJournal journal(s.journal, &s.manifest);
    EXPECT_EQ(journal.dropped_bytes(), half.size());
    EXPECT_EQ(fs::file_size(s.journal), good_size);
    journal.Append(ExampleRecords()[2]);
  }
  const JournalContents after = ReadCaptureJournal(s.journal, &s.manifest);
  ExpectSameRecords(after.records, ExampleRecords());
  EXPECT_EQ(after.dropped_bytes, 0u);
}

TEST(CaptureJournal, GarbageLastLineWithNewlineIsTorn) {
  ExampleSession s;
  {
    CaptureJournal journal(s.journal);
    journal.Append(ExampleRecords()[0]);
  }
  // Some file systems leave zeros after a crash.
  AppendText(s.journal, std::string(17, '\0') + "\n");
  const JournalContents read = ReadCaptureJournal(s.journal);
  EXPECT_EQ(read.records.size(), 1u);
  EXPECT_EQ(read.dropped_bytes, 18u);
  CaptureJournal journal(s.journal);
  journal.Append(Record(1, "anything"));
  EXPECT_EQ(ReadCaptureJournal(s.journal).records.size(), 2u);
}

TEST(CaptureJournal, BadLineInTheMiddleNamesTheLine) {
  ExampleSession s;
  {
    CaptureJournal journal(s.journal, &s.manifest);
    for (const auto& r : ExampleRecords()) journal.Append(r);
  }
  const std::string text = Slurp(s.journal);
  const auto second = text.find('\n') + 1;
  std::string broken = text;
  broken.insert(second, "#");  // line 2 is no longer JSON
  Spit(s.journal, broken);
  auto message = ErrorOf([&] { ReadCaptureJournal(s.journal); }, s.journal);
  EXPECT_NE(message.find("'line 2'"), std::string::npos) << message;
  EXPECT_NE(message.find("not valid JSON"), std::string::npos) << message;
  // The writer refuses it too, rather than appending after garbage.
  ErrorOf([&] { CaptureJournal journal(s.journal); }, s.journal);

  Spit(s.journal, text.substr(0, second) + "\n" + text.substr(second));  // an empty line
  message = ErrorOf([&] { ReadCaptureJournal(s.journal); }, s.journal);
  EXPECT_NE(message.find("'line 2'"), std::string::npos) << message;
}

TEST(CaptureJournal, OrderAndPlanAreChecked) {
  ExampleSession s;
  const auto line = [](const JournalRecord& r) {
    json files = json::array();
    for (const auto& f : r.files) files.push_back({{"path", f.path}, {"bytes", f.bytes}});
    return json{{"seq", r.seq}, {"step", r.step}, {"time_utc", r.time_utc}, {"files", files}}.dump() + "\n";
  };
  const auto first = line(Record(0, "dark-frame"));
  // Errors on the last line too: a complete line of JSON is not torn.
  Spit(s.journal, first + line(Record(2, "laser-cal-m0")));
  EXPECT_NE(ErrorOf([&] { ReadCaptureJournal(s.journal); }, s.journal).find("'line 2.seq'"), std::string::npos);
  Spit(s.journal, first + line(Record(1, "dark-frame")));
  EXPECT_NE(ErrorOf([&] { ReadCaptureJournal(s.journal); }, s.journal).find("already recorded"), std::string::npos);
  Spit(s.journal, first + line(Record(1, "elsewhere")));
  EXPECT_EQ(ReadCaptureJournal(s.journal).records.size(), 2u);  // no plan given: any id
  EXPECT_NE(ErrorOf([&] { ReadCaptureJournal(s.journal, &s.manifest); }, s.journal).find("not in the plan"),
            std::string::npos);
}

TEST(CaptureJournal, HostileLinesNameLineAndField) {
  ExampleSession s;
  const std::string good = R"({"seq":0,"step":"dark-frame","time_utc":"2025-06-01T13:00:00Z","files":[]})";
  const std::string deep = std::string(300000, '[') + std::string(300000, ']');
  std::string many_files = R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[)";
  for (int i = 0; i < 100000; ++i) many_files += i ? ",0" : "0";
  many_files += "]}";
  const std::vector<std::pair<std::string, std::string>> lines = {
      {R"({"seq":-1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[]})", "line 2.seq"},
      {R"({"seq":"1","step":"a","time_utc":"2025-06-01T13:00:00Z","files":[]})", "line 2.seq"},
      {R"({"seq":null,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[]})", "line 2.seq"},
      {R"({"seq":1e308,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[]})", "line 2.seq"},
      {R"({"seq":1,"step":"","time_utc":"2025-06-01T13:00:00Z","files":[]})", "line 2.step"},
      {R"({"seq":1,"step":"a","time_utc":"now","files":[]})", "line 2.time_utc"},
      {R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z"})", "line 2.files"},
      {R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":{}})", "line 2.files"},
      {R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[{"path":"/etc/passwd","bytes":1}]})",
       "line 2.files[0].path"},
      {R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[{"path":"x/../../y","bytes":1}]})",
       "line 2.files[0].path"},
      {R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[{"path":"x","bytes":-1}]})",
       "line 2.files[0].bytes"},
      {R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[{"path":"x","bytes":1.5}]})",
       "line 2.files[0].bytes"},
      {R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[{"path":"x"}]})", "line 2.files[0].bytes"},
      {R"({"seq":1,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[],"ok":true})", "line 2.ok"},
      {R"({"seq":1e400,"step":"a","time_utc":"2025-06-01T13:00:00Z","files":[]})", "line 2"},
      {R"([1,2,3])", "line 2"},
      {R"("record")", "line 2"},
      {deep, "line 2"},
      {many_files, "line 2.files"},
      {std::string(kMaxJournalLineBytes + 1, ' '), "line 2"},
  };
  for (const auto& [text, field] : lines) {
    SCOPED_TRACE(field + ": " + text.substr(0, 60));
    // In the middle of the journal, and as its (complete) last line.
    Spit(s.journal, good + "\n" + text + "\n" + good + "\n");
    auto message = ErrorOf([&] { ReadCaptureJournal(s.journal); }, s.journal);
    EXPECT_NE(message.find("'" + field), std::string::npos) << message.substr(0, 300);
    const bool json_text = json::accept(text);
    Spit(s.journal, good + "\n" + text + "\n");
    if (json_text) {
      message = ErrorOf([&] { ReadCaptureJournal(s.journal); }, s.journal);
      EXPECT_NE(message.find("'" + field), std::string::npos) << message.substr(0, 300);
    } else {
      EXPECT_EQ(ReadCaptureJournal(s.journal).records.size(), 1u);
    }
  }
}

TEST(CaptureJournalFuzz, EveryTruncationKeepsTheCompleteRecords) {
  ExampleSession s;
  {
    CaptureJournal journal(s.journal, &s.manifest);
    for (const auto& r : ExampleRecords()) journal.Append(r);
  }
  const std::string text = Slurp(s.journal);
  for (std::size_t n = 0; n <= text.size(); ++n) {
    SCOPED_TRACE(n);
    const std::string cut = text.substr(0, n);
    Spit(s.journal, cut);
    const auto complete = static_cast<std::size_t>(std::count(cut.begin(), cut.end(), '\n'));
    const auto last_newline = cut.rfind('\n');
    const std::size_t intact = last_newline == std::string::npos ? 0 : last_newline + 1;
    const JournalContents read = ReadCaptureJournal(s.journal, &s.manifest);
    ASSERT_EQ(read.records.size(), complete);
    EXPECT_EQ(read.intact_bytes, intact);
    EXPECT_EQ(read.dropped_bytes, n - read.intact_bytes);
  }
}

TEST(CaptureJournalFuzz, MutatedBytesAreReadOrRejectedNeverCrash) {
  ExampleSession s;
  {
    CaptureJournal journal(s.journal, &s.manifest);
    for (const auto& r : ExampleRecords()) journal.Append(r);
  }
  const std::string text = Slurp(s.journal);
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::size_t> offset(0, text.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  int rejected = 0, read = 0;
  for (int i = 0; i < 2000; ++i) {
    std::string mutated = text;
    mutated[offset(rng)] = static_cast<char>(byte(rng));
    Spit(s.journal, mutated);
    try {
      const JournalContents c = ReadCaptureJournal(s.journal, &s.manifest);
      EXPECT_LE(c.records.size(), 3u);
      EXPECT_EQ(c.intact_bytes + c.dropped_bytes, mutated.size());
      ++read;
    } catch (const core::Error& e) {
      ++rejected;
      EXPECT_NE(std::string(e.what()).find(s.journal.string()), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a mesocap::Error: " << e.what();
    }
  }
  EXPECT_GT(rejected, 1000);
  EXPECT_GT(read, 100);  // a damaged last line is a torn tail
}

// ---- a session opened for processing ------------------------------------

TEST(CapturedSession, RefusesASessionBeingWrittenAndAnIncompleteOne) {
  ExampleSession s;
  {
    CaptureJournal writer(s.journal, &s.manifest);
    writer.Append(ExampleRecords()[0]);
    const std::string message = ErrorOf<core::Error>([&] { CapturedSession open(s.root); }, s.root);
    EXPECT_NE(message.find("being written"), std::string::npos) << message;
  }
  std::string message = ErrorOf<core::Error>([&] { CapturedSession open(s.root, {{}, "process btf"}); }, s.root);
  EXPECT_NE(message.find("1 of 4 steps done (missing laser-cal-m0, sweep-t000-m0, dark-frame)"), std::string::npos)
      << message;
  message = ErrorOf<core::Error>([&] { CapturedSession open(s.root, {{"laser-*", "dark-frame"}}); }, s.root);
  EXPECT_NE(message.find("(missing sweep-t000-m0)"), std::string::npos) << message;
  const CapturedSession open(s.root, {{"*"}});
  EXPECT_EQ(open.missing_steps(), (std::vector<std::string>{"laser-cal-m0", "sweep-t000-m0", "dark-frame"}));
  EXPECT_TRUE(open.IsDone("btf-t000-a000-l0"));
  // While it is open for reading, no capture can write it.
  EXPECT_NE(ErrorOf<core::Error>([&] { CaptureJournal writer(s.journal, &s.manifest); }, s.journal).find("another"),
            std::string::npos);
}

// Every byte of every journaled file is covered: a change anywhere is named
// by IntactFile (what the readers use) and by DamagedSessionFiles (verify).
TEST(CapturedSession, AnyChangedByteOfAJournaledFileIsDetected) {
  ExampleSession s;
  {
    CaptureJournal writer(s.journal, &s.manifest);
    for (const auto& r : ExampleRecords()) writer.Append(r);
  }
  ASSERT_TRUE(ReadCaptureJournal(s.journal, &s.manifest).records[0].files[0].xxh3.has_value());
  std::mt19937 rng(3);
  for (const char* path : {"btf/000.exr", "btf/001.exr", "laser.json"}) {
    SCOPED_TRACE(path);
    const std::string original = Slurp(s.root / path);
    for (std::size_t at = 0; at < original.size(); at += 1 + rng() % 97) {
      std::string bytes = original;
      bytes[at] = static_cast<char>(bytes[at] ^ (1 << (rng() % 8)));
      Spit(s.root / path, bytes);
      const CapturedSession open(s.root, {{"*"}});
      const std::string message = ErrorOf([&] { open.IntactFile(path); }, s.root / path);
      EXPECT_NE(message.find("'checksum': content changed after it was written"), std::string::npos) << message;
      const auto damaged = DamagedSessionFiles(s.root, s.manifest, ReadCaptureJournal(s.journal, &s.manifest).records);
      ASSERT_EQ(damaged.size(), 2u);
      EXPECT_EQ(damaged[0].path, "calibration/rig.json") << "the example's calibration was never written";
      EXPECT_EQ(damaged[1].path, path);
    }
    Spit(s.root / path, original.substr(0, original.size() - 1));
    EXPECT_NE(
        ErrorOf([&] { CapturedSession(s.root, {{"*"}}).IntactFile(path); }, s.root / path).find("bytes, expected"),
        std::string::npos);
    Spit(s.root / path, original);
  }
  EXPECT_EQ(DamagedSessionFiles(s.root, s.manifest, ReadCaptureJournal(s.journal, &s.manifest).records).size(), 1u);
  EXPECT_THROW(CapturedSession(s.root, {{"*"}}).IntactFile("btf/002.exr"), core::Error) << "not journaled";
}

// A step done again (its files were damaged) supersedes its record with
// "replaces"; a repeat without it, or one that replaces another record, is
// refused.
TEST(CaptureJournal, RedoneStepsReplaceTheirRecord) {
  ExampleSession s;
  {
    CaptureJournal writer(s.journal, &s.manifest);
    for (const auto& r : ExampleRecords()) writer.Append(r);
    EXPECT_THROW(writer.Append(Record(3, "laser-cal-m0", {F("laser.json", 2)})), core::Error);
    writer.Redo("laser-cal-m0");
    EXPECT_FALSE(writer.IsDone("laser-cal-m0"));
    Spit(s.root / "laser.json", "{ }");
    writer.Append(Record(3, "laser-cal-m0", {F("laser.json", 3)}));
    EXPECT_TRUE(writer.IsDone("laser-cal-m0"));
  }
  const JournalContents read = ReadCaptureJournal(s.journal, &s.manifest);
  ASSERT_EQ(read.records.size(), 4u);
  EXPECT_EQ(read.records[3].replaces, 1u);
  EXPECT_EQ(LatestRecords(read.records).at("laser-cal-m0")->files[0].bytes, 3u);
  EXPECT_EQ(CapturedSession(s.root, {{"*"}}).IntactFile("laser.json"), s.root / "laser.json");

  const std::string text = Slurp(s.journal);
  const auto line = [&](std::uint64_t seq, const std::string& step, const std::string& extra) {
    return "{\"seq\":" + std::to_string(seq) + ",\"step\":\"" + step +
           "\",\"time_utc\":\"2025-06-01T13:00:05Z\",\"files\":[]" + extra + "}\n";
  };
  for (const auto& [bad, field] : std::vector<std::pair<std::string, std::string>>{
           {line(4, "laser-cal-m0", ""), "line 5.step"},
           {line(4, "laser-cal-m0", ",\"replaces\":1"), "line 5.step"},
           {line(4, "sweep-t000-m0", ",\"replaces\":2"), "line 5.replaces"},
           {line(4, "laser-cal-m0", ",\"replaces\":4"), "line 5.replaces"}}) {
    SCOPED_TRACE(bad);
    Spit(s.journal, text + bad);
    const std::string message = ErrorOf([&] { ReadCaptureJournal(s.journal, &s.manifest); }, s.journal);
    EXPECT_NE(message.find("'" + field + "'"), std::string::npos) << message;
  }
}

// A version 2 session's journal must carry each file's hash; a version 1
// session (sizes only, the calibration a plain path) still reads.
TEST(CaptureJournal, HashesAreRequiredInVersion2AndAbsentInVersion1) {
  ExampleSession s;
  Spit(s.journal,
       "{\"seq\":0,\"step\":\"laser-cal-m0\",\"time_utc\":\"2025-06-01T13:00:05Z\","
       "\"files\":[{\"path\":\"laser.json\",\"bytes\":2}]}\n");
  EXPECT_NE(ErrorOf([&] { ReadCaptureJournal(s.journal, &s.manifest); }, s.journal).find("'line 1.files[0].xxh3_64'"),
            std::string::npos);
  json v1 = json::parse(Slurp(s.root / kSessionManifestName));
  v1["version"] = 1;
  v1["calibration"] = "calibration/rig.json";
  Spit(s.root / kSessionManifestName, v1.dump());
  const SessionManifest old = ReadSessionManifest(s.root);
  EXPECT_EQ(old.version, 1);
  EXPECT_EQ(old.calibration, "calibration/rig.json");
  EXPECT_FALSE(old.calibration_checksum.has_value());
  ASSERT_EQ(ReadCaptureJournal(s.journal, &old).records.size(), 1u);
  const CapturedSession open(s.root, {{"*"}});
  EXPECT_EQ(open.IntactFile("laser.json"), s.root / "laser.json");
  Spit(s.root / "laser.json", "{}}");
  EXPECT_THROW(open.IntactFile("laser.json"), core::FormatError) << "sizes are still checked";
}

}  // namespace
}  // namespace mesocap::formats
