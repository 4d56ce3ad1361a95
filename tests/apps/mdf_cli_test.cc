// `mesocap process mdf` and `mesocap eval mdf` run as a user would, on a
// tiny-rig session recorded by `mesocap simulate`: the error table against
// `mesocap groundtruth`, and bad input (missing calibration entries, a
// sequence of the wrong frame size, a calibration of another rig) giving a
// clear error and writing nothing.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "core/file_checksum.h"
#include "core/json_field_reader.h"
#include "formats/frame_sequence.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;

using testing::CommandResult;
using testing::Mesocap;
using testing::Slurp;

class MdfCliTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TemporaryDirectory();
    session_ = dir_->path() / "session";
    truth_ = dir_->path() / "truth";
    ASSERT_EQ(Mesocap("simulate --scene blocks --rig tiny --out " + session_.string()).exit_code, 0);
    ASSERT_EQ(Mesocap("groundtruth --scene blocks --rig tiny --out " + truth_.string()).exit_code, 0);
  }
  static void TearDownTestSuite() { delete dir_; }

  static inline testing::TemporaryDirectory* dir_ = nullptr;
  static inline fs::path session_, truth_;
};

TEST_F(MdfCliTest, ProcessAndEvaluate) {
  testing::TemporaryDirectory out;
  const fs::path material = out / "blocks";
  const CommandResult p = Mesocap("process mdf --session " + session_.string() + " --calibration " +
                                  (session_ / "calibration.json").string() + " --out " + material.string());
  ASSERT_EQ(p.exit_code, 0) << p.err;
  EXPECT_TRUE(fs::exists(material / "mdf.exr"));
  EXPECT_TRUE(fs::exists(material / "mdf8.tif"));
  // The per-texel confidence: 0 exactly where the MDF is unknown, in (0, 1]
  // where it is measured.
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(material);
  const core::Mdf mdf = formats::ReadMdf(material, manifest);
  const core::Image confidence = formats::ReadMdfConfidence(material, manifest);
  long measured = 0;
  for (std::size_t i = 0; i < confidence.size(); ++i) {
    const float d = mdf.distance_mm.data()[i], c = confidence.data()[i];
    if (std::isnan(d)) {
      EXPECT_EQ(c, 0.0f) << "texel-view " << i;
    } else if (std::isfinite(d)) {
      EXPECT_GT(c, 0.0f) << "texel-view " << i;
      ++measured;
    }
  }
  EXPECT_GT(measured, 0);
  const CommandResult e = Mesocap("eval mdf --json --truth " + truth_.string() + " --estimate " + material.string() +
                                  " --out " + (out / "table.json").string());
  ASSERT_EQ(e.exit_code, 0) << e.err;
  const auto table = nlohmann::json::parse(e.out);
  EXPECT_EQ(table, core::ReadJsonFile(out / "table.json"));
  for (const char* name : {"median_mm", "p95_mm", "median_texels", "p95_texels", "coverage", "false_no_hit_rate",
                           "false_hit_rate", "no_hit_coverage"}) {
    EXPECT_TRUE(table["overall"].contains(name)) << name;
  }
  ASSERT_EQ(table["by_polar_angle"].size(), 6u);
  EXPECT_EQ(table["by_polar_angle"][2]["theta_min_deg"], 30.0);
  EXPECT_EQ(table["by_polar_angle"][2]["theta_max_deg"], 45.0);
  // The tiny rig's cameras are coarse (a pixel covers ~0.43 mm, 2.3 texel
  // widths of its 12 mm / 64 grid), so its bounds are looser than the small
  // rig's acceptance (tests/mdf/mdf_pipeline_test.cc). Measured:
  // median 0.39 texels, coverage 0.875 (0.99 inside the sample pocket).
  const auto& overall = table["overall"];
  EXPECT_LT(overall["median_texels"].get<double>(), 0.5);
  EXPECT_LT(overall["median_mm"].get<double>(), 0.1);
  EXPECT_GT(overall["coverage"].get<double>(), 0.85);
  EXPECT_EQ(overall["false_no_hit_rate"].get<double>(), 0.0);
  EXPECT_TRUE(overall["false_hit_rate"].is_null()) << "blocks has no through-holes";
  // The 30-45 degree camera beats the 60-75 degree one.
  EXPECT_LT(table["by_polar_angle"][2]["median_texels"].get<double>(),
            table["by_polar_angle"][4]["median_texels"].get<double>());
  const CommandResult inside =
      Mesocap("eval mdf --json --inside-sample-only --truth " + truth_.string() + " --estimate " + material.string());
  ASSERT_EQ(inside.exit_code, 0) << inside.err;
  EXPECT_GT(nlohmann::json::parse(inside.out)["overall"]["coverage"].get<double>(), 0.97);
  const CommandResult text = Mesocap("eval mdf --truth " + truth_.string() + " --estimate " + material.string());
  EXPECT_NE(text.out.find("overall"), std::string::npos);
}

// `process mdf` with the session's calibration edited by `edit`: refused with
// an error holding `expected`, and nothing written.
void ExpectCalibrationRefused(const fs::path& session, const std::function<void(nlohmann::json&)>& edit,
                              const std::string& expected) {
  testing::TemporaryDirectory out;
  nlohmann::json calibration = core::ReadJsonFile(session / "calibration.json");
  edit(calibration);
  std::ofstream(out / "calibration.json") << calibration.dump();
  const CommandResult p = Mesocap("process mdf --session " + session.string() + " --calibration " +
                                  (out / "calibration.json").string() + " --out " + (out / "m").string());
  EXPECT_NE(p.exit_code, 0);
  EXPECT_NE(p.err.find(expected), std::string::npos) << p.err;
  EXPECT_FALSE(fs::exists(out / "m"));
}

TEST_F(MdfCliTest, CalibrationMissingACameraWritesNothing) {
  ExpectCalibrationRefused(
      session_, [](nlohmann::json& c) { c["cameras"].erase(1); }, "cam1");
}

TEST_F(MdfCliTest, CalibrationOfAnotherRigWritesNothing) {
  ExpectCalibrationRefused(
      session_,
      [](nlohmann::json& c) {
        for (auto& camera : c["cameras"]) camera["image_size"] = {320, 240};  // the small rig's
      },
      "another rig");
}

TEST_F(MdfCliTest, SequenceWithWrongFrameSizeWritesNothingAndKeepsExistingOutput) {
  testing::TemporaryDirectory out;
  // A copy of the session whose first sweep of cam0 has 64 x 48 frames (the
  // first one read: nothing is written however late a file fails, and the
  // output is only written once every sweep is in).
  const fs::path session = out / "session";
  fs::copy(session_, session, fs::copy_options::recursive);
  const fs::path bad = session / "laser" / "t0_loc0_cam0.tif";
  ASSERT_TRUE(fs::exists(bad));
  {
    formats::FrameSequenceWriter writer(bad, 64, 48, 1);
    for (int f = 0; f < 64; ++f) writer.Append(core::Image(64, 48, 1, 0.1f));
    writer.Commit();
  }
  // Journaled as it is now, so that the frame size itself is what is refused.
  const core::FileChecksum sum = core::ComputeFileChecksum(bad);
  std::string journal;
  std::istringstream lines(Slurp(session / "journal.jsonl"));
  for (std::string line; std::getline(lines, line);) {
    nlohmann::json record = nlohmann::json::parse(line);
    for (auto& file : record["files"]) {
      if (file["path"] == "laser/t0_loc0_cam0.tif") {
        file["bytes"] = sum.bytes;
        file["xxh3_64"] = core::ChecksumText(sum.xxh3);
      }
    }
    journal += record.dump() + "\n";
  }
  std::ofstream(session / "journal.jsonl", std::ios::binary | std::ios::trunc) << journal;
  // An existing package (what --replace may replace), with a file of the user's.
  ASSERT_EQ(Mesocap("groundtruth --rig tiny --texture-size 4 --out " + (out / "m").string()).exit_code, 0);
  std::ofstream(out / "m" / "keep.txt") << "old";
  const CommandResult p =
      Mesocap("process mdf --session " + session.string() + " --calibration " +
              (session / "calibration.json").string() + " --out " + (out / "m").string() + " --replace");
  EXPECT_NE(p.exit_code, 0);
  EXPECT_NE(p.err.find("t0_loc0_cam0.tif"), std::string::npos) << p.err;
  EXPECT_NE(p.err.find("128x96"), std::string::npos) << p.err;
  EXPECT_EQ(Slurp(out / "m" / "keep.txt"), "old");
  // Without --replace an existing output is refused before any work.
  const CommandResult q = Mesocap("process mdf --session " + session_.string() + " --calibration " +
                                  (session_ / "calibration.json").string() + " --out " + (out / "m").string());
  EXPECT_NE(q.exit_code, 0);
  EXPECT_NE(q.err.find("exists"), std::string::npos) << q.err;
}

TEST_F(MdfCliTest, EvalRejectsMismatchedPackages) {
  testing::TemporaryDirectory out;
  ASSERT_EQ(
      Mesocap("groundtruth --scene blocks --rig tiny --texture-size 32 --out " + (out / "t32").string()).exit_code, 0);
  const CommandResult e = Mesocap("eval mdf --truth " + truth_.string() + " --estimate " + (out / "t32").string());
  EXPECT_NE(e.exit_code, 0);
  EXPECT_NE(e.err.find("64x64"), std::string::npos) << e.err;
}

// The measured MDF carried into the BTF's package (`process btf --mdf`): one
// material with both parts, which renders; an MDF on another texture grid is
// refused naming its manifest and field, and nothing is written.
TEST_F(MdfCliTest, ProcessBtfCarriesTheMeasuredMdfIntoAMaterialThatRenders) {
  testing::TemporaryDirectory out;
  const fs::path mdf = out / "mdf", material = out / "material", coarse = out / "mdf6";
  const std::string session = " --session " + session_.string();
  ASSERT_EQ(Mesocap("-q process mdf" + session + " --texture-size 8 --out " + mdf.string()).exit_code, 0);
  const CommandResult b =
      Mesocap("-q process btf" + session + " --texture-size 8 --mdf " + mdf.string() + " --out " + material.string());
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const formats::MaterialManifest m = formats::ReadMaterialManifest(material);
  const formats::MaterialManifest measured = formats::ReadMaterialManifest(mdf);
  ASSERT_TRUE(m.mdf && m.factored_btf && m.ambient);
  EXPECT_EQ(m.mdf->confidence, measured.mdf->confidence);
  EXPECT_EQ(m.description.d_max_mm, measured.description.d_max_mm);
  const core::Mdf carried = formats::ReadMdf(material, m), original = formats::ReadMdf(mdf, measured);
  ASSERT_EQ(carried.distance_mm.size(), original.distance_mm.size());
  for (std::size_t i = 0; i < carried.distance_mm.size(); ++i) {
    const float c = carried.distance_mm.data()[i], o = original.distance_mm.data()[i];
    ASSERT_TRUE(c == o || (std::isnan(c) && std::isnan(o))) << i;
  }
  std::ofstream(out / "scene.json") << R"({"format": "mesocap.scene", "version": 1,
    "camera": {"position": [0, -60, 40], "look_at": [0, 0, 0], "up": [0, 0, 1], "fov_y_deg": 40},
    "light": {"position": [40, -40, 120], "intensity": 30000, "ambient": 0.2},
    "objects": [{"name": "torus", "shape": "torus", "major_radius": 20, "minor_radius": 8, "segments": 48,
                 "tube_segments": 24, "tiles": [4, 2], "material": "material"}]})";
  // Mesa's libraries leak at exit under the sanitizers (as for every GL test:
  // tests/CMakeLists.txt); the leak check stays on for the other commands here.
  const CommandResult r = Mesocap(
      "-q render " + (out / "scene.json").string() + " --mode full --size 64x48 --out " + (out / "frame.png").string(),
      "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:detect_stack_use_after_return=1");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(out / "frame.png"));

  ASSERT_EQ(Mesocap("-q process mdf" + session + " --texture-size 6 --out " + coarse.string()).exit_code, 0);
  const CommandResult refused = Mesocap("-q process btf" + session + " --texture-size 8 --mdf " + coarse.string() +
                                        " --out " + (out / "refused").string());
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.err.find((coarse / "manifest.json").string()), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("width"), std::string::npos) << refused.err;
  EXPECT_NE(refused.err.find("expected the BTF's texture size 8"), std::string::npos) << refused.err;
  EXPECT_FALSE(fs::exists(out / "refused"));
}

}  // namespace
}  // namespace mesocap
