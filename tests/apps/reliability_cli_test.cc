// Nothing lost, nothing silently wrong: what --replace may replace, what a
// resume redoes, what processing refuses, what verify and the readers catch,
// and what a killed run leaves behind, on a real tiny session (S) and a
// ground-truth package (T), through the real binary.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>

#include "tests/common/killed_writer.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

// These tests are about what is written and kept, not which representation
// the budget picks: one representation keeps each factoring to one SVD.
constexpr char kOneRepresentation[] = " --layout paper --color rgb";

namespace fs = std::filesystem;
using testing::CommandResult;
using testing::Mesocap;
using testing::Slurp;

void WriteBytes(const fs::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

// Every regular file under `dir` by relative path, with its bytes.
std::map<std::string, std::string> Contents(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), dir).generic_string()] = Slurp(e.path());
  }
  return files;
}

class ReliabilityCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TemporaryDirectory();
    ASSERT_EQ(Mesocap("-q simulate --rig tiny --seed 3 --out " + Session().string()).exit_code, 0);
    ASSERT_EQ(Mesocap("-q groundtruth --rig tiny --texture-size 8 --out " + Truth().string()).exit_code, 0);
  }
  static void TearDownTestSuite() { delete dir_; }

  static fs::path Session() { return *dir_ / "S"; }
  static fs::path Truth() { return *dir_ / "T"; }

  // A copy of S or T to damage.
  fs::path Copy(const fs::path& from, const std::string& name) {
    const fs::path to = work_ / name;
    fs::copy(from, to, fs::copy_options::recursive);
    return to;
  }

  static testing::TemporaryDirectory* dir_;
  testing::TemporaryDirectory work_;
};

testing::TemporaryDirectory* ReliabilityCliTest::dir_ = nullptr;

// --replace replaces only what the command writes, never anything else and
// never the command's own input; what is there is intact afterwards.
TEST_F(ReliabilityCliTest, ReplaceRefusesWhatTheCommandDoesNotWriteAndItsInput) {
  const fs::path notes = work_ / "J";
  fs::create_directories(notes);
  WriteBytes(notes / "notes.txt", "precious");
  const fs::path s = Copy(Session(), "S");
  const fs::path t = Copy(Truth(), "T");
  const auto session_before = Contents(s);
  const auto truth_before = Contents(t);
  const std::string S = s.string(), T = t.string(), J = notes.string();
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"compress --in " + T + " --out " + J + " --replace", "replaces only a material package"},
      {"compress --in " + T + " --out " + T + " --replace", "this command's input"},
      {"process btf --session " + S + " --out " + S + " --replace", "this command's input"},
      {"process btf --session " + S + " --out " + J + " --replace", "replaces only a material package"},
      {"process mdf --session " + S + " --out " + S + " --replace", "this command's input"},
      {"groundtruth --rig tiny --texture-size 4 --out " + J + " --replace", "replaces only a material package"},
      {"export bonn --in " + T + " --form ubo2003 --out " + J + " --replace", "replaces only a UBO2003 image folder"},
      {"export bonn --in " + T + " --form ubo2003 --out " + T + " --replace", "this command's input"},
      {"export bonn --in " + T + " --form fmf --out " + (notes / "notes.txt").string() + " --replace",
       "replaces only a Bonn BTF file"},
  };
  for (const auto& [args, expected] : cases) {
    SCOPED_TRACE(args);
    const CommandResult r = Mesocap("-q " + args);
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
  EXPECT_EQ(Slurp(notes / "notes.txt"), "precious");
  EXPECT_EQ(Contents(notes).size(), 1u);
  EXPECT_EQ(Contents(s), session_before);
  EXPECT_EQ(Contents(t), truth_before);
  EXPECT_EQ(testing::CountTemporaries(work_.path()), 0);
  // What the command writes is replaced.
  ASSERT_EQ(Mesocap("-q compress --in " + T + kOneRepresentation + " --out " + (work_ / "C").string()).exit_code, 0);
  EXPECT_EQ(Mesocap("-q compress --in " + T + " --rank 1 --out " + (work_ / "C").string() + " --replace").exit_code, 0);
  EXPECT_EQ(testing::CountTemporaries(work_.path()), 0);
}

// --resume re-checks every journaled file: a truncated PNG and a truncated
// calibration are captured (written) again and said so, and the session
// equals the undamaged one byte for byte.
TEST_F(ReliabilityCliTest, ResumeRedoesDamagedFilesAndSaysSo) {
  const fs::path s = Copy(Session(), "S");
  const auto before = Contents(s);
  const fs::path png = s / "btf" / "t1_a0_l1_cam0.png";
  ASSERT_TRUE(fs::exists(png));
  WriteBytes(png, Slurp(png).substr(0, 1));
  WriteBytes(s / "calibration.json", Slurp(s / "calibration.json").substr(0, 100));
  const CommandResult r = Mesocap("simulate --rig tiny --seed 3 --resume --out " + s.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("btf/t1_a0_l1_cam0.png is 1 bytes"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("capturing step btf-t1_a0_l1 again"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("calibration.json is 100 bytes"), std::string::npos) << r.err;
  auto after = Contents(s);
  // The journal gains the record that replaces the damaged step's; all data are as before.
  const std::string journal = after["journal.jsonl"];
  EXPECT_EQ(journal.substr(0, before.at("journal.jsonl").size()), before.at("journal.jsonl"));
  EXPECT_NE(journal.find("\"replaces\""), std::string::npos);
  after.erase("journal.jsonl");
  auto expected = before;
  expected.erase("journal.jsonl");
  EXPECT_EQ(after, expected);
  EXPECT_EQ(Mesocap("-q verify " + s.string()).exit_code, 0);
}

// Processing reads the journal: an incomplete session is refused with how
// to finish it, unless --allow-incomplete names the steps to leave out.
TEST_F(ReliabilityCliTest, ProcessingRefusesAnIncompleteSession) {
  const fs::path s = Copy(Session(), "S");
  const std::string journal = Slurp(s / "journal.jsonl");
  WriteBytes(s / "journal.jsonl", "");
  const CommandResult btf =
      Mesocap("-q process btf --session " + s.string() + kOneRepresentation + " --out " + (work_ / "B").string());
  EXPECT_EQ(btf.exit_code, 1);
  EXPECT_NE(btf.err.find("0 of 34 steps done"), std::string::npos) << btf.err;
  EXPECT_NE(btf.err.find("simulate --resume"), std::string::npos) << btf.err;
  // The first 27 steps: the last turntable angle's 4 BTF images and 3 sweeps missing.
  std::size_t at = 0;
  for (int i = 0; i < 27; ++i) at = journal.find('\n', at) + 1;
  WriteBytes(s / "journal.jsonl", journal.substr(0, at));
  const CommandResult mdf = Mesocap("-q process mdf --session " + s.string() + " --out " + (work_ / "M").string());
  EXPECT_EQ(mdf.exit_code, 1);
  EXPECT_NE(mdf.err.find("27 of 34 steps done"), std::string::npos) << mdf.err;
  const CommandResult named = Mesocap("process btf --session " + s.string() + " --out " + (work_ / "B").string() +
                                      " --allow-incomplete 'btf-t3_*'");
  EXPECT_EQ(named.exit_code, 1) << "the sweeps of t3 are missing too";
  EXPECT_NE(named.err.find("laser-sweep-t3"), std::string::npos) << named.err;
  // All but the last sweep: a BTF needs no sweep.
  at = journal.rfind('\n', journal.size() - 2) + 1;
  WriteBytes(s / "journal.jsonl", journal.substr(0, at));
  const CommandResult allowed = Mesocap("process btf --session " + s.string() + " --out " + (work_ / "B").string() +
                                        kOneRepresentation + " --allow-incomplete 'laser-sweep-*'");
  EXPECT_EQ(allowed.exit_code, 0) << allowed.err;
  EXPECT_NE(allowed.err.find("leaving out 1 of 34 planned steps"), std::string::npos) << allowed.err;
  EXPECT_FALSE(fs::exists(work_ / "M"));
}

// Any changed byte of any data file is named by verify and refused by the
// reader that reads it; the old behaviour decoded a flipped EXR or zip TIFF
// block without error.
TEST_F(ReliabilityCliTest, BitFlipsAreNamedByVerifyAndRefusedByReaders) {
  EXPECT_EQ(Mesocap("-q verify " + Session().string()).exit_code, 0);
  EXPECT_EQ(Mesocap("-q verify " + Truth().string()).exit_code, 0);
  const fs::path t = Copy(Truth(), "T");
  std::string mdf = Slurp(t / "mdf.exr");
  mdf[mdf.size() / 2] ^= 0x01;
  WriteBytes(t / "mdf.exr", mdf);
  CommandResult v = Mesocap("-q verify " + t.string());
  EXPECT_EQ(v.exit_code, 1);
  EXPECT_NE(v.err.find((t / "mdf.exr").string() + ": content changed"), std::string::npos) << v.err;
  CommandResult e = Mesocap("-q eval mdf --truth " + Truth().string() + " --estimate " + t.string());
  EXPECT_EQ(e.exit_code, 1);
  EXPECT_NE(e.err.find("mdf.exr: field 'checksum'"), std::string::npos) << e.err;

  const fs::path s = Copy(Session(), "S");
  const fs::path tif = s / "laser" / "t2_loc1_cam1.tif";
  std::string frames = Slurp(tif);
  frames[frames.size() / 3] ^= 0x40;
  WriteBytes(tif, frames);
  v = Mesocap("-q verify " + s.string());
  EXPECT_EQ(v.exit_code, 1);
  EXPECT_NE(v.err.find("t2_loc1_cam1.tif: content changed"), std::string::npos) << v.err;
  EXPECT_NE(v.err.find("1 of 69 files"), std::string::npos) << v.err;
  const CommandResult p = Mesocap("-q process mdf --session " + s.string() + " --out " + (work_ / "M").string());
  EXPECT_EQ(p.exit_code, 1);
  EXPECT_NE(p.err.find("t2_loc1_cam1.tif: field 'checksum'"), std::string::npos) << p.err;
  EXPECT_FALSE(fs::exists(work_ / "M"));
}

// What a killed run left beside its output is removed at the next start of
// the same command: only its own names, only when their process is gone.
TEST_F(ReliabilityCliTest, StaleTemporariesOfTheSameOutputAreRemoved) {
  const std::string dead = std::to_string(testing::DeadPid());
  const fs::path out = work_ / "B";
  for (const std::string& name : {".B.tmp-" + dead + "-0", ".B.assembled.tmp-" + dead + "-1"}) {
    fs::create_directories(work_ / name / "btf");
    WriteBytes(work_ / name / "btf" / "view_0000.exr", std::string(1000, 'x'));
  }
  const std::string live = ".B.tmp-" + std::to_string(::getpid()) + "-7";
  const std::string other = ".A.tmp-" + dead + "-0";
  fs::create_directories(work_ / live);
  fs::create_directories(work_ / other);
  const CommandResult r =
      Mesocap("process btf --session " + Session().string() + kOneRepresentation + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("left by a killed run"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(work_ / (".B.tmp-" + dead + "-0")));
  EXPECT_FALSE(fs::exists(work_ / (".B.assembled.tmp-" + dead + "-1")));
  EXPECT_TRUE(fs::exists(work_ / live)) << "a live process's temporary";
  EXPECT_TRUE(fs::exists(work_ / other)) << "another output's temporary";
}

}  // namespace
}  // namespace mesocap
