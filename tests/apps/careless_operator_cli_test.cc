// What a careless operator or a damaged disk hands the CLI's readers: a plan
// step out of its rules, a step damaged in an unfinished session, a journal
// that is a looping link, an 8-bit frame behind a matching hash, a package
// too large to write, a value of null. Each is refused in one line that names
// the file and the field, before any work, with nothing left behind.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/file_checksum.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

using nlohmann::json;
using testing::CommandResult;
using testing::ExpectOneErrorLine;
using testing::Mesocap;
namespace fs = std::filesystem;

// A whole one-sweep session in `dir`/s (about a second).
fs::path SimulateSession(const testing::TemporaryDirectory& dir) {
  const std::string rig = testing::WriteRig(dir / "rig.json");
  const CommandResult r =
      Mesocap("-q simulate --scene flat --samples-per-pixel-side 1 --rig " + rig + " --out " + (dir / "s").string());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return dir / "s";
}

json ReadManifest(const fs::path& session) { return core::ReadJsonFile(session / "manifest.json"); }
void WriteManifest(const fs::path& session, const json& manifest) {
  std::ofstream(session / "manifest.json", std::ios::trunc) << manifest.dump(1);
}

// The index of the plan's first step of `kind`.
std::size_t FirstStep(const json& manifest, const std::string& kind) {
  const json& steps = manifest["plan"]["steps"];
  for (std::size_t s = 0; s < steps.size(); ++s) {
    if (steps[s]["kind"] == kind) return s;
  }
  ADD_FAILURE() << "no step of kind " << kind;
  return 0;
}

// verify, info and both processing commands read a plan step by the same
// rules: a sweep with three times its frames' offsets, a turntable angle of
// 1e300.
TEST(CarelessOperator, EveryReaderAppliesThePlanStepsRules) {
  testing::TemporaryDirectory dir;
  const fs::path session = SimulateSession(dir);
  const json intact = ReadManifest(session);
  const fs::path manifest_file = session / "manifest.json";

  json long_offsets = intact;
  const std::size_t sweep = FirstStep(intact, "laser_sweep");
  json& offsets = long_offsets["plan"]["steps"][sweep]["offset_mm"];
  const json once = offsets;
  for (int copy = 0; copy < 2; ++copy) offsets.insert(offsets.end(), once.begin(), once.end());
  json far_turn = intact;
  const std::size_t image = FirstStep(intact, "btf_image");
  far_turn["plan"]["steps"][image]["turntable_deg"] = 1e300;

  const std::string field_offsets = "field 'plan[" + std::to_string(sweep) +
                                    "].offset_mm': expected one number per frame of the rig's sweep "
                                    "(laser.frames_per_sweep = 8), got 24 entries";
  const std::string field_turn = "field 'plan[" + std::to_string(image) +
                                 "].turntable_deg': expected a finite number in [-360, 360], got number 1e+300";
  for (const auto& [manifest, problem] : {std::pair(long_offsets, field_offsets), std::pair(far_turn, field_turn)}) {
    WriteManifest(session, manifest);
    for (const std::string& command :
         {"verify " + session.string(), "info " + session.string(),
          "process btf --texture-size 4 --session " + session.string() + " --out " + (dir / "btf").string(),
          "process mdf --texture-size 4 --session " + session.string() + " --out " + (dir / "mdf").string()}) {
      SCOPED_TRACE(command);
      ExpectOneErrorLine(Mesocap("-q " + command), manifest_file.string() + ": " + problem);
    }
  }
  EXPECT_FALSE(fs::exists(dir / "btf"));
  EXPECT_FALSE(fs::exists(dir / "mdf"));
}

TEST(CarelessOperator, InfoReadsTheRigsCalibrationBoard) {
  testing::TemporaryDirectory dir;
  json rig = testing::OnePositionRig("tiny");
  rig["calibration_board"]["board"] = "a board of any kind";
  const std::string file = testing::WriteRig(dir / "rig.json", rig);
  ExpectOneErrorLine(Mesocap("info " + file),
                     file +
                         ": field 'calibration_board.board': board \"a board of any kind\": expected "
                         "chessboard:COLSxROWS:SQUARE_MM or charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICTIONARY");
}

// An unfinished session whose manifest was damaged is said to be damaged, not
// taken for a session started with other options.
TEST(CarelessOperator, AResumeNamesTheDamagedStep) {
  testing::TemporaryDirectory dir;
  const fs::path session = SimulateSession(dir);
  const std::string journal = testing::Slurp(session / "journal.jsonl");
  std::ofstream(session / "journal.jsonl", std::ios::trunc) << journal.substr(0, journal.find('\n') + 1);
  const json intact = ReadManifest(session);
  const std::size_t last = intact["plan"]["steps"].size() - 1;
  const std::string step = "plan[" + std::to_string(last) + "]";
  const std::string resume = "-q simulate --scene flat --samples-per-pixel-side 1 --rig " +
                             (dir / "rig.json").string() + " --resume --out " + session.string();
  const std::string manifest_file = (session / "manifest.json").string();

  json unknown = intact;
  unknown["plan"]["steps"][last]["stray"] = 1;
  WriteManifest(session, unknown);
  EXPECT_NE(Mesocap(resume).err.find(manifest_file + ": field '" + step + ".stray': unknown member; expected only "),
            std::string::npos);
  json missing = intact;
  missing["plan"]["steps"][last].erase("arc_deg");
  WriteManifest(session, missing);
  ExpectOneErrorLine(Mesocap(resume), manifest_file + ": field '" + step + ".arc_deg': missing");
  json no_seed = intact;
  no_seed["plan"]["steps"][last]["recording"].erase("seed");
  WriteManifest(session, no_seed);
  ExpectOneErrorLine(Mesocap(resume), manifest_file + ": field '" + step +
                                          ".recording': differs from plan[0].recording, which every step shares: the "
                                          "manifest is damaged");
  WriteManifest(session, intact);
  EXPECT_EQ(Mesocap(resume).exit_code, 0);
}

TEST(CarelessOperator, AJournalThatIsALoopingLinkIsNamed) {
  testing::TemporaryDirectory dir;
  const fs::path session = SimulateSession(dir);
  fs::remove(session / "journal.jsonl");
  fs::create_symlink("journal.jsonl", session / "journal.jsonl");
  const std::string journal = (session / "journal.jsonl").string();
  for (const char* command : {"verify ", "info "}) {
    ExpectOneErrorLine(Mesocap(std::string(command) + session.string()),
                       journal + ": cannot read: Too many levels of symbolic links");
  }
  // Never a session with no step done.
  ExpectOneErrorLine(
      Mesocap("process btf --texture-size 4 --session " + session.string() + " --out " + (dir / "btf").string()),
      journal + ": cannot open: Too many levels of symbolic links");
}

// docs/FORMATS.md: a session's frames are 16-bit. One rewritten as 8-bit,
// with the journal's size and hash made to match, is still refused.
TEST(CarelessOperator, An8BitFrameBehindAMatchingHashIsRefused) {
  testing::TemporaryDirectory dir;
  const fs::path session = SimulateSession(dir);
  std::string journal = testing::Slurp(session / "journal.jsonl");
  // The first BTF image's record.
  json record;
  std::size_t begin = 0;
  for (std::size_t end; (end = journal.find('\n', begin)) != std::string::npos; begin = end + 1) {
    record = json::parse(journal.substr(begin, end - begin));
    if (record["step"].get<std::string>().rfind("btf-", 0) == 0) break;
  }
  const std::size_t end = journal.find('\n', begin);
  const fs::path file = session / record["files"][0]["path"].get<std::string>();
  core::WriteImage(file, core::ReadImage(file), core::PixelEncoding::kUInt8);
  const core::FileChecksum sum = core::ComputeFileChecksum(file);
  record["files"][0]["bytes"] = sum.bytes;
  record["files"][0]["xxh3_64"] = core::ChecksumText(sum.xxh3);
  journal.replace(begin, end - begin, record.dump());
  std::ofstream(session / "journal.jsonl", std::ios::trunc) << journal;

  const CommandResult verify = Mesocap("-q verify " + session.string());
  EXPECT_EQ(verify.exit_code, 0) << "the hash matches: " << verify.err;
  ExpectOneErrorLine(
      Mesocap("-q process btf --texture-size 4 --session " + session.string() + " --out " + (dir / "btf").string()),
      file.string() + ": field 'pixel type': expected uint16, got uint8");
  EXPECT_FALSE(fs::exists(dir / "btf"));
}

TEST(CarelessOperator, InfoDecodesEveryPixelOfAnImage) {
  testing::TemporaryDirectory dir;
  const fs::path png = dir / "frame.png";
  core::Image image(64, 64, 3);
  for (std::size_t i = 0; i < image.size(); ++i) image.data()[i] = static_cast<float>(i % 97) / 97.0f;
  core::WriteImage(png, image, core::PixelEncoding::kUInt16);
  ASSERT_EQ(Mesocap("-q info " + png.string()).exit_code, 0);
  const std::string bytes = testing::Slurp(png);
  std::ofstream(png, std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() / 2);
  ExpectOneErrorLine(Mesocap("-q info " + png.string()),
                     png.string() +
                         ": field 'pixels': cannot read: the file is damaged, cut short or not PNG (mesocap -v logs "
                         "the decoder's own words)");
}

// The package's size limit is known from the rig and the flags: refused at
// once, not after the ground truth is computed.
TEST(CarelessOperator, GroundTruthTooLargeToWriteIsRefusedFirst) {
  testing::TemporaryDirectory dir;
  json rig = testing::OnePositionRig("tiny");
  rig["turntable"]["angles_deg"] = json::array();
  for (int a = 0; a < 4096; ++a) rig["turntable"]["angles_deg"].push_back(a * 360.0 / 4096);
  const std::string file = testing::WriteRig(dir / "rig.json", rig);
  const CommandResult r =
      Mesocap("-q groundtruth --rig " + file + " --texture-size 256 --out " + (dir / "gt").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.rfind("mesocap: error: " + (dir / "gt").string() + ": full BTF of 256x256 texels x ", 0), 0u)
      << r.err;
  EXPECT_NE(r.err.find(" of float data; at most 64 GiB accepted\n"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "gt"));
}

TEST(CarelessOperator, ErrorsSayWhatTheyMeanInTheProjectsWords) {
  testing::TemporaryDirectory dir;
  json rig = testing::OnePositionRig("tiny");
  rig["sample"]["size_mm"] = nullptr;
  const std::string file = testing::WriteRig(dir / "rig.json", rig);
  ExpectOneErrorLine(Mesocap("info " + file),
                     file + ": field 'sample.size_mm': expected a finite number in [0.001, 10000], got null");
  // The output's folder, not the writer's temporary, is named.
  const std::string scene = std::string(MESOCAP_SOURCE_DIR) + "/render/scenes/cylinder.json";
  const std::string out = (dir / "nodir" / "out.png").string();
  ExpectOneErrorLine(Mesocap("-q render " + scene + " --out " + out),
                     out + ": no folder " + (dir / "nodir").string() + " to write it in");
}

// Two packages that cannot be compared: the estimate's manifest field is
// named, not "truth and estimate differ".
TEST(CarelessOperator, EvalMdfNamesTheFieldThatDiffers) {
  testing::TemporaryDirectory dir;
  const std::string truth = (dir / "truth").string(), estimate = (dir / "estimate").string();
  for (const std::string& out : {truth, estimate}) {
    ASSERT_EQ(Mesocap("-q groundtruth --scene flat --rig tiny --texture-size 4 --out " + out).exit_code, 0);
  }
  json manifest = core::ReadJsonFile(dir / "estimate" / "manifest.json");
  manifest["physical_size_mm"][1] = 16.0;
  std::ofstream(dir / "estimate" / "manifest.json", std::ios::trunc) << manifest.dump(1);
  ExpectOneErrorLine(Mesocap("-q eval mdf --truth " + truth + " --estimate " + estimate),
                     estimate +
                         "/manifest.json: field 'physical_size_mm': 12.000 x 16.000 mm here, 12.000 x 12.000 mm "
                         "in the truth's (" +
                         truth +
                         "/manifest.json); evaluate against a ground truth of the estimate's grid (mesocap groundtruth "
                         "--texture-size, --views)");
}

}  // namespace
}  // namespace mesocap
