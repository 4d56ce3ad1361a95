// Nothing silently wrong at the CLI: flags out of range, misspelt rig
// members, a resume that cannot be one, allocations the machine cannot hold
// and a device that stops the capture each give one error line naming the
// flag, field or step; -q is quiet; library chatter never reaches stderr;
// outputs are replaced only with --replace.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/common/mesocap_command.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

using testing::CommandResult;
using testing::ExpectOneErrorLine;
using testing::Mesocap;
using testing::Slurp;
namespace fs = std::filesystem;

std::string Simulate(const testing::TemporaryDirectory& dir, const std::string& rig, const std::string& extra = "",
                     int samples_per_pixel_side = 1) {
  return "simulate --scene flat --samples-per-pixel-side " + std::to_string(samples_per_pixel_side) + " --rig " + rig +
         " --out " + (dir / "s").string() + extra;
}

TEST(StrictCli, QuietMeansNoProgressAndNoInfo) {
  testing::TemporaryDirectory dir;
  const CommandResult r = Mesocap("-q " + Simulate(dir, testing::WriteRig(dir / "rig.json")));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.err, "");
  EXPECT_EQ(r.out, "");
  const CommandResult loud = Mesocap(Simulate(dir, testing::WriteRig(dir / "rig.json"), " --resume"));
  EXPECT_NE(loud.err.find("[info]"), std::string::npos) << "without -q the log still speaks: " << loud.err;
}

TEST(StrictCli, ResumeNeedsASession) {
  testing::TemporaryDirectory dir;
  const CommandResult r = Mesocap("-q " + Simulate(dir, testing::WriteRig(dir / "rig.json"), " --resume"));
  ExpectOneErrorLine(
      r, (dir / "s").string() + ": no capture session to resume (no such folder); leave out --resume to start one");
  EXPECT_FALSE(fs::exists(dir / "s"));
  // A folder whose session creation was killed (at most the manifest's
  // temporary in it) is started.
  fs::create_directories(dir / "s");
  std::ofstream(dir / "s" / ".manifest.tmp-999999999-0.json") << "{";
  EXPECT_EQ(Mesocap("-q " + Simulate(dir, testing::WriteRig(dir / "rig.json"), " --resume")).exit_code, 0);
  EXPECT_TRUE(fs::exists(dir / "s" / "manifest.json"));
}

TEST(StrictCli, AResumeWithOtherOptionsNamesTheField) {
  testing::TemporaryDirectory dir;
  const std::string rig = testing::WriteRig(dir / "rig.json");
  ASSERT_EQ(Mesocap("-q " + Simulate(dir, rig)).exit_code, 0);
  ExpectOneErrorLine(
      Mesocap("-q " + Simulate(dir, rig, " --resume --seed 5")),
      (dir / "s").string() + ": the session was started with other options: recording.seed was 1, now 5");
  nlohmann::json other = testing::OneSweepRig();
  other["cameras"][1]["bit_depth"] = 10;
  ExpectOneErrorLine(
      Mesocap("-q " + Simulate(dir, testing::WriteRig(dir / "other.json", other), " --resume")),
      (dir / "s").string() + ": the session was started with another rig: rig.cameras[1].bit_depth was 12, now 10");
}

// A camera that is gone at the first operation: the error names the step the
// capture stopped at and the command that resumes it.
TEST(StrictCli, ADisconnectBeforeTheFirstStepSaysWhereAndHowToResume) {
  testing::TemporaryDirectory dir;
  const std::string rig = testing::WriteRig(dir / "rig.json");
  std::ofstream(dir / "faults.json")
      << R"({"format": "mesocap.faults", "version": 1, "camera_disconnect": {"device": "cam0", "at": [1]}})";
  const CommandResult r = Mesocap("-q " + Simulate(dir, rig, " --faults " + (dir / "faults.json").string()));
  ExpectOneErrorLine(r, (dir / "s").string() +
                            ": step \"laser-calibration-loc0_h0\" (1 of 5): camera cam0: disconnected; 0 of 5 steps "
                            "are journaled; resume with: mesocap simulate --resume --out " +
                            (dir / "s").string() + " --scene flat --rig " + rig + " --seed 1 --faults " +
                            (dir / "faults.json").string() + " --samples-per-pixel-side 1 --interreflection-rays 0");
}

TEST(StrictCli, MisspeltRigMembersAreRefusedBeforeAnythingIsWritten) {
  testing::TemporaryDirectory dir;
  nlohmann::json rig = testing::OneSweepRig();
  rig["laser"]["sweep_storge"] = "analysis";
  const std::string file = testing::WriteRig(dir / "typo.json", rig);
  const CommandResult r = Mesocap("-q " + Simulate(dir, file));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("typo.json: field 'laser.sweep_storge': unknown member; expected only backend,"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "s"));
}

// 16384 x 16384 cameras are inside the rig format's range; their first hits
// at 3 x 3 rays a pixel (190 GB) are not inside any machine's memory.
TEST(StrictCli, ACameraTooLargeForMemoryNamesTheSizeAndTheLimit) {
  testing::TemporaryDirectory dir;
  nlohmann::json rig = testing::OneSweepRig();
  for (auto& camera : rig["cameras"]) camera["image_size"] = {16384, 16384};
  const CommandResult r = Mesocap("-q " + Simulate(dir, testing::WriteRig(dir / "huge.json", rig), "", 3));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.rfind("mesocap: error: needs ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find(" bytes for the first hits of the 2 simulated cameras of " + (dir / "huge.json").string() +
                       " (cameras[0].image_size: 16384 x 16384 pixels, 9 rays each; smaller cameras or a lower "
                       "--samples-per-pixel-side need less); limit "),
            std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find(" bytes (this machine's memory)\n"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "s"));
}

// Under ulimit -v the limit is what the address space leaves, and the
// message says so: a need below the machine's memory is still refused
// before anything is written.
TEST(StrictCli, AnAddressSpaceLimitIsTheLimitTheMessageNames) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory does not start under ulimit -v";
#endif
  testing::TemporaryDirectory dir;
  nlohmann::json rig = testing::OneSweepRig();
  for (auto& camera : rig["cameras"]) camera["image_size"] = {8192, 8192};  // 1.5 GB of first hits at 1 ray
  const std::string file = testing::WriteRig(dir / "large.json", rig);
  const CommandResult r = Mesocap("-q " + Simulate(dir, file), "ulimit -v 1048576;");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.err.rfind("mesocap: error: needs ", 0), 0u) << r.err;
  EXPECT_NE(r.err.find("left of the process's address-space limit of 1073741824 bytes (ulimit -v)\n"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(dir / "s"));
}

TEST(StrictCli, NumericFlagsAreRangeCheckedNamingFlagAndRange) {
  for (const char* value : {"-1", "0"}) {
    const CommandResult r =
        Mesocap(std::string("process mdf --session s --calibration c.json --out p --d-max-mm ") + value);
    EXPECT_NE(r.exit_code, 0);
    EXPECT_EQ(r.err, std::string("mesocap: error: --d-max-mm: ") + value + " is outside [1e-06, 10000]\n");
  }
  const CommandResult scale = Mesocap("import bonn --in . --out p --d-max-mm 1 --scale 1e9");
  EXPECT_EQ(scale.err, "mesocap: error: --scale: 1e9 is outside [1e-06, 1e+06]\n");
  const CommandResult size = Mesocap("render scene.json --out x.png --size 0x10");
  EXPECT_EQ(size.err, "mesocap: error: --size: expected each side in [1, 8192], got \"0x10\"\n");
}

// libpng prints "libpng error: ..." itself and OpenImageIO appends its own
// lines; the user sees one line.
TEST(StrictCli, ACorruptImageGivesOneLineAndNoLibraryChatter) {
  testing::TemporaryDirectory dir;
  ASSERT_EQ(Mesocap("-q " + Simulate(dir, testing::WriteRig(dir / "rig.json"))).exit_code, 0);
  // Half of a capture image as a height-map scene: a session's own files
  // are refused by their checksum before any decoder runs, a scene file is not.
  const fs::path png = dir / "height.png";
  const std::string bytes = Slurp(dir / "s" / "btf" / "t0_a0_l0_cam0.png");
  std::ofstream(png, std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() / 2);
  for (const char* verbosity : {"", "-q "}) {
    const CommandResult r = Mesocap(std::string(verbosity) + "groundtruth --rig tiny --texture-size 4 --scene " +
                                    png.string() + " --out " + (dir / "m").string());
    EXPECT_EQ(r.exit_code, 1);
    EXPECT_EQ(r.err.find("libpng"), std::string::npos) << r.err;
    const std::string last = r.err.substr(r.err.rfind('\n', r.err.size() - 2) + 1);
    // The decoder's own words ("IDAT: ...") stay in the debug log.
    EXPECT_EQ(last, "mesocap: error: " + png.string() +
                        ": field 'pixels': cannot read: the file is damaged, cut short or not PNG (mesocap -v logs the "
                        "decoder's own words)\n")
        << r.err;
    EXPECT_EQ(std::count(last.begin(), last.end(), '\n'), 1) << r.err;
  }
}

TEST(StrictCli, JsonErrorsNameFileAndPositionWithoutLibraryIds) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "overflow.json") << R"({"format": "mesocap.rig", "version": 1e400})";
  ExpectOneErrorLine(Mesocap("info " + (dir / "overflow.json").string()),
                     (dir / "overflow.json").string() + ": not valid JSON: a number beyond the range of a double");
  std::ofstream(dir / "torn.json") << R"({"format": "mesocap.rig", "version" 1})";
  ExpectOneErrorLine(Mesocap("info " + (dir / "torn.json").string()),
                     (dir / "torn.json").string() + ": not valid JSON (at byte 37)");
}

TEST(StrictCli, RenderAndEvalMdfReplaceTheirOutputOnlyWhenAsked) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "picture.png") << "keep me";
  const std::string scene = std::string(MESOCAP_SOURCE_DIR) + "/render/scenes/cylinder.json";
  ExpectOneErrorLine(Mesocap("render " + scene + " --out " + (dir / "picture.png").string()),
                     (dir / "picture.png").string() +
                         ": already exists; choose another output, or --replace to replace an image there");
  EXPECT_EQ(Slurp(dir / "picture.png"), "keep me");
  // Not an image, so not what render writes: kept even with --replace.
  ExpectOneErrorLine(Mesocap("render " + scene + " --out " + (dir / "picture.png").string() + " --replace"),
                     (dir / "picture.png").string() +
                         ": --replace replaces only an image, and this is not one; move it away or choose another "
                         "output");
  EXPECT_EQ(Slurp(dir / "picture.png"), "keep me");

  const std::string gt = (dir / "gt").string();
  ASSERT_EQ(Mesocap("-q groundtruth --scene flat --rig tiny --texture-size 4 --out " + gt).exit_code, 0);
  std::ofstream(dir / "table.json") << "keep me";
  const std::string eval = "eval mdf --truth " + gt + " --estimate " + gt + " --out " + (dir / "table.json").string();
  const std::string report = "an MDF error report (JSON with \"overall\" and \"by_polar_angle\")";
  ExpectOneErrorLine(Mesocap(eval), (dir / "table.json").string() +
                                        ": already exists; choose another output, or --replace to replace " + report +
                                        " there");
  ExpectOneErrorLine(Mesocap(eval + " --replace"), (dir / "table.json").string() + ": --replace replaces only " +
                                                       report +
                                                       ", and this is not one; move it away or choose another output");
  EXPECT_EQ(Slurp(dir / "table.json"), "keep me");
  fs::remove(dir / "table.json");
  ASSERT_EQ(Mesocap(eval).exit_code, 0);
  // Never the command's own input, with --replace or not.
  const std::string own = "eval mdf --truth " + gt + " --estimate " + gt + " --out " + gt + "/manifest.json --replace";
  EXPECT_NE(Mesocap(own).err.find("this command's input"), std::string::npos);
  ASSERT_EQ(Mesocap(eval + " --replace").exit_code, 0);
  EXPECT_TRUE(nlohmann::json::parse(Slurp(dir / "table.json")).is_object());
}

}  // namespace
}  // namespace mesocap
