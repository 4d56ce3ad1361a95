// Runs the real `mesocap` binary as a user would and checks exit codes,
// stdout and the one-line errors on stderr.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <limits>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>
#include <string>

#include "core/json_field_reader.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

using testing::CommandResult;
using testing::Mesocap;
using testing::Slurp;

std::string RigFile(const std::string& name) { return std::string(MESOCAP_SOURCE_DIR) + "/sim/rigs/" + name + ".json"; }

TEST(Cli, VersionAndHelp) {
  const CommandResult v = Mesocap("--version");
  EXPECT_EQ(v.exit_code, 0);
  EXPECT_NE(v.out.find("mesocap 0."), std::string::npos) << v.out;
  const CommandResult h = Mesocap("info --help");
  EXPECT_EQ(h.exit_code, 0);
  EXPECT_NE(h.out.find("--json"), std::string::npos);
  EXPECT_NE(Mesocap("").exit_code, 0) << "a subcommand is required";
  EXPECT_NE(Mesocap("no-such-command").exit_code, 0);
}

TEST(Cli, InfoOnRigDescriptionPrintsJson) {
  const CommandResult r = Mesocap("info --json " + RigFile("paper"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["kind"], "rig");
  EXPECT_EQ(j["views"], 96);
  EXPECT_EQ(j["laser_locations"], 26);
  ASSERT_EQ(j["laser_ray_sines"].size(), 26u);
  EXPECT_EQ(j["laser_ray_sines"][0].size(), 8u);  // one per camera
}

TEST(Cli, InfoOnRigDescriptionNamesItsWorstLaserCameraPair) {
  // The small rig's worst pair (docs/BENCHMARKS.md): the
  // top mount (84.375 degrees) at arc 0 with camera 0 at 78.75 degrees
  // elevation, 5.625 degrees below it on the same side.
  const auto j = nlohmann::json::parse(Mesocap("info --json " + RigFile("small")).out);
  const auto& worst = j["smallest_laser_ray_sine"];
  EXPECT_NEAR(worst["sine"].get<double>(), std::sin(5.625 * std::numbers::pi / 180), 1e-9);
  EXPECT_EQ(worst["camera"], "cam0");
  EXPECT_EQ(worst["location"], 6);
  EXPECT_FALSE(worst["below_triangulation_limit"].get<bool>());
}

// The acceptance check of the Foundation issue: a hostile file gives a
// non-zero exit and one line on stderr naming the file and the field.
TEST(Cli, InfoOnHostileFileIsOneLineNamingFileAndField) {
  testing::TemporaryDirectory dir;
  auto rig = core::ReadJsonFile(RigFile("tiny"));
  rig["cameras"][0]["focal_px"] = -5;
  const auto file = dir / "hostile-rig.json";
  std::ofstream(file) << rig.dump();
  const CommandResult r = Mesocap("info " + file.string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_EQ(r.out, "");
  ASSERT_FALSE(r.err.empty());
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "more than one line: " << r.err;
  EXPECT_NE(r.err.find("hostile-rig.json"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("cameras[0].focal_px"), std::string::npos) << r.err;

  std::ofstream(dir / "calib.json") << R"({"format": "mesocap.calibration", "version": 7})";
  const CommandResult c = Mesocap("info " + (dir / "calib.json").string());
  EXPECT_EQ(c.exit_code, 1);
  EXPECT_NE(c.err.find("calib.json"), std::string::npos) << c.err;
  EXPECT_NE(c.err.find("version"), std::string::npos) << c.err;

  std::ofstream(dir / "torn.json") << R"({"format": "mesocap.calibr)";
  const CommandResult t = Mesocap("info " + (dir / "torn.json").string());
  EXPECT_EQ(t.exit_code, 1);
  EXPECT_NE(t.err.find("not valid JSON"), std::string::npos) << t.err;

  const CommandResult missing = Mesocap("info " + (dir / "nothing-here").string());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("nothing-here"), std::string::npos);
}

TEST(Cli, GroundTruthWritesAPackageAndNeverOverwritesByAccident) {
  testing::TemporaryDirectory dir;
  const std::string out = (dir / "flat").string();
  const CommandResult r = Mesocap("-q groundtruth --scene flat --rig tiny --texture-size 8 --out " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const CommandResult info = Mesocap("info --json " + out);
  ASSERT_EQ(info.exit_code, 0) << info.err;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["kind"], "material");
  EXPECT_EQ(j["texture_size"], nlohmann::json({8, 8}));
  EXPECT_EQ(j["parts"]["calibration"]["cameras"], 2);
  EXPECT_TRUE(j["parts"]["btf_full"].get<bool>());

  // A second run without --replace is refused and the package is intact.
  const auto manifest_before = Slurp(dir / "flat" / "manifest.json");
  const CommandResult again = Mesocap("-q groundtruth --scene box --rig tiny --texture-size 8 --out " + out);
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("already exists"), std::string::npos) << again.err;
  EXPECT_EQ(Slurp(dir / "flat" / "manifest.json"), manifest_before);
  EXPECT_EQ(Mesocap("-q groundtruth --scene box --rig tiny --texture-size 8 --replace --out " + out).exit_code, 0);
  EXPECT_NE(Slurp(dir / "flat" / "manifest.json"), manifest_before);
}

TEST(Cli, GroundTruthRejectsUnknownSceneAndRigWithoutOutput) {
  testing::TemporaryDirectory dir;
  const CommandResult scene = Mesocap("groundtruth --scene velvet --out " + (dir / "a").string());
  EXPECT_EQ(scene.exit_code, 1);
  EXPECT_NE(scene.err.find("velvet"), std::string::npos) << scene.err;
  const CommandResult rig = Mesocap("groundtruth --scene flat --rig huge --out " + (dir / "b").string());
  EXPECT_EQ(rig.exit_code, 1);
  EXPECT_NE(rig.err.find("paper, small, tiny"), std::string::npos) << rig.err;
  EXPECT_TRUE(std::filesystem::is_empty(dir.path())) << "a failed run left output behind";
}

// A rig whose backing board lies inside the scene's slab (weave is 3 mm
// deep): `simulate` refuses it naming the field before it writes anything.
TEST(Cli, SimulateRefusesABackingInsideTheSlabWithoutOutput) {
  testing::TemporaryDirectory dir;
  nlohmann::json rig = core::ReadJsonFile(std::filesystem::path(MESOCAP_SOURCE_DIR) / "sim" / "rigs" / "tiny.json");
  rig["sample"]["backing"]["depth_mm"] = 2.5;
  const std::filesystem::path rig_file = dir / "shallow.json";
  std::ofstream(rig_file) << rig.dump();
  const CommandResult r =
      Mesocap("simulate --scene weave --rig " + rig_file.string() + " --out " + (dir / "s").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("sample.backing.depth_mm"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "s")) << "a refused run left a session behind";
}

// A capture stopped by a fault the runner cannot cure exits 1 naming the
// step and the device, keeps what it finished, and --resume completes it.
TEST(Cli, SimulateStopsOnADisconnectAndResumes) {
  testing::TemporaryDirectory dir;
  testing::WriteRig(dir / "rig.json");
  std::ofstream(dir / "faults.json")
      << R"({"format": "mesocap.faults", "version": 1, "camera_disconnect": {"device": "cam1", "at": [20]}})";
  const std::string args = "-q simulate --scene flat --samples-per-pixel-side 1 --rig " + (dir / "rig.json").string() +
                           " --out " + (dir / "s").string();
  const CommandResult broken = Mesocap(args + " --faults " + (dir / "faults.json").string());
  EXPECT_EQ(broken.exit_code, 1);
  EXPECT_NE(broken.err.find("laser-sweep-t0_loc0"), std::string::npos) << broken.err;
  EXPECT_NE(broken.err.find("cam1"), std::string::npos) << broken.err;
  const auto progress = [&] { return nlohmann::json::parse(Mesocap("info --json " + (dir / "s").string()).out); };
  EXPECT_EQ(progress()["completed_steps"], 4);
  EXPECT_FALSE(progress()["complete"].get<bool>());
  const CommandResult resumed = Mesocap(args + " --resume");
  ASSERT_EQ(resumed.exit_code, 0) << resumed.err;
  EXPECT_EQ(progress()["completed_steps"], 5);
  EXPECT_TRUE(progress()["complete"].get<bool>());
}

// `mesocap compress` factors a ground-truth package: a flat Lambertian
// sample needs one term under a 1e-4 budget; the MDF, ambient term and
// calibration come through; the figures land in the error report.
TEST(Cli, CompressFactorsAGroundTruthPackage) {
  testing::TemporaryDirectory dir;
  const std::string gt = (dir / "gt").string(), out = (dir / "c").string();
  ASSERT_EQ(Mesocap("-q groundtruth --scene flat --rig tiny --texture-size 8 --out " + gt).exit_code, 0);
  const CommandResult r = Mesocap("-q compress --in " + gt + " --out " + out + " --max-error 1e-4 --color ycbcr");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const formats::MaterialManifest m = formats::ReadMaterialManifest(out);
  ASSERT_TRUE(m.factored_btf.has_value());
  EXPECT_EQ(m.factored_btf->rank, 1);
  EXPECT_EQ(m.factored_btf->color, core::BtfFactorColor::kYCbCr);
  EXPECT_FALSE(m.full_btf);
  EXPECT_TRUE(m.mdf && m.ambient && m.calibration);
  const auto report = formats::ReadErrorReport(out, m)["btf_compression"];
  EXPECT_EQ(report["rank"], 1);
  EXPECT_LT(report["measured_relative_rms"].get<double>(), 1e-4);
  EXPECT_NEAR(formats::ReadFactoredBtf(out, m).Reconstruct(2, 3, 4, 5).x(), 0.5 / 3.14159265358979, 1e-5);
  // The layout was left to choose: paper, per_texel, clustered at three
  // cluster counts and per_view were factored, and the smallest that meets
  // the budget kept.
  ASSERT_EQ(report["candidates"].size(), 6u);
  long long smallest = std::numeric_limits<long long>::max();
  for (const auto& c : report["candidates"]) {
    if (c["meets_budget"].get<bool>()) smallest = std::min(smallest, c["factor_bytes"].get<long long>());
  }
  EXPECT_EQ(report["factor_bytes"], smallest);
  EXPECT_EQ(report["layout"], ToString(m.factored_btf->layout));

  // A byte budget: the factors fit it.
  const std::string bytes = (dir / "b").string();
  ASSERT_EQ(Mesocap("-q compress --in " + gt + " --out " + bytes + " --max-bytes 60000").exit_code, 0);
  const auto byte_report = formats::ReadErrorReport(bytes, formats::ReadMaterialManifest(bytes))["btf_compression"];
  EXPECT_LE(byte_report["factor_bytes"].get<long long>(), 60000);
  EXPECT_EQ(byte_report["candidates"].size(), 12u);
  EXPECT_NE(byte_report["representation_reason"].get<std::string>().find("most accurate"), std::string::npos);

  // Both --rank and --max-error, or a package without a full BTF: refused,
  // nothing written.
  EXPECT_NE(Mesocap("compress --in " + gt + " --out " + (dir / "x").string() + " --rank 2 --max-error 0.1").exit_code,
            0);
  const CommandResult again = Mesocap("compress --in " + out + " --out " + (dir / "y").string());
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("no full BTF"), std::string::npos) << again.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "x"));
  EXPECT_FALSE(std::filesystem::exists(dir / "y"));
}

// `mesocap eval btf --json` prints the issue's figures; a compressed weave's
// error is the one the compression measured.
TEST(Cli, EvalBtfPrintsTheErrorOfACompressedPackage) {
  testing::TemporaryDirectory dir;
  const std::string gt = (dir / "gt").string(), out = (dir / "c").string();
  ASSERT_EQ(Mesocap("-q groundtruth --scene weave --rig tiny --texture-size 8 --out " + gt).exit_code, 0);
  ASSERT_EQ(Mesocap("-q compress --in " + gt + " --out " + out + " --rank 2").exit_code, 0);
  const CommandResult r = Mesocap("eval btf --json --truth " + gt + " --estimate " + out);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["rank"], 2);
  const double measured =
      formats::ReadErrorReport(out, formats::ReadMaterialManifest(out))["btf_compression"]["measured_relative_rms"];
  EXPECT_NEAR(j["overall"]["relative_rms"].get<double>(), measured, 1e-6 * measured);
  EXPECT_GT(j["overall"]["psnr_db"].get<double>(), 0.0);
  ASSERT_FALSE(j["by_polar_angle"].empty());
  for (const auto& band : j["by_polar_angle"]) {
    for (const char* key : {"theta_min_deg", "theta_max_deg", "psnr_db", "relative_rms"})
      EXPECT_TRUE(band.contains(key)) << key;
  }
  // The truth against itself is exact: PSNR infinite (null), error 0, no rank.
  const auto self = nlohmann::json::parse(Mesocap("eval btf --json --truth " + gt + " --estimate " + gt).out);
  EXPECT_EQ(self["overall"]["relative_rms"], 0.0);
  EXPECT_TRUE(self["overall"]["psnr_db"].is_null());
  EXPECT_TRUE(self["rank"].is_null());
  // A truth on another grid is refused with the reason.
  ASSERT_EQ(
      Mesocap("-q groundtruth --scene weave --rig tiny --texture-size 4 --out " + (dir / "gt4").string()).exit_code, 0);
  const CommandResult bad = Mesocap("eval btf --truth " + (dir / "gt4").string() + " --estimate " + out);
  EXPECT_EQ(bad.exit_code, 1);
  EXPECT_NE(bad.err.find("texture size"), std::string::npos) << bad.err;
}

TEST(Cli, ABtfPlanRecordsTheBtfImagesAloneAndProcessesToTheSameBtf) {
  // `simulate --plan btf`: the capture plan's BTF image steps and nothing
  // else; `process btf` turns it into the BTF a whole capture session gives
  // (same seed, same images).
  testing::TemporaryDirectory dir;
  const std::string btf = (dir / "btf").string(), whole = (dir / "whole").string();
  ASSERT_EQ(Mesocap("-q simulate --scene weave --rig tiny --plan btf --out " + btf).exit_code, 0);
  const auto manifest = nlohmann::json::parse(Slurp(std::filesystem::path(btf) / "manifest.json"));
  const auto tiny = nlohmann::json::parse(Slurp(RigFile("tiny")));
  const std::size_t images = tiny["turntable"]["angles_deg"].size() * tiny["light_arc"]["angles_deg"].size() *
                             tiny["lamps"]["elevations_deg"].size();
  ASSERT_EQ(manifest["plan"]["steps"].size(), images);
  for (const auto& step : manifest["plan"]["steps"]) EXPECT_EQ(step["kind"], "btf_image") << step.dump();
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::path(btf) / "laser"));

  ASSERT_EQ(Mesocap("-q simulate --scene weave --rig tiny --out " + whole).exit_code, 0);
  for (const auto& [session, out] : {std::pair{btf, "m-btf"}, std::pair{whole, "m-whole"}}) {
    const CommandResult r =
        Mesocap("-q process btf --session " + session + " --out " + (dir / out).string() + " --texture-size 8 --full");
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  EXPECT_EQ(Slurp(dir / "m-btf" / "btf" / "view_0000.exr"), Slurp(dir / "m-whole" / "btf" / "view_0000.exr"));
  const CommandResult mdf = Mesocap("-q process mdf --session " + btf + " --out " + (dir / "mdf").string());
  EXPECT_NE(mdf.exit_code, 0) << "a BTF-only session has no sweeps";
  EXPECT_NE(mdf.err.find("plans no laser sweep"), std::string::npos) << mdf.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "mdf"));
}

// `mesocap process btf` on a tiny-rig BTF session of the flat sample: the package
// holds the factored (and full) BTF, the ambient term and the assembly's
// figures, and its BTF is within the rig's error of the ground truth; each
// camera's gain is the calibration's unless --gain overrides it; a missing
// image is one error line naming it, and nothing is written.
TEST(Cli, ProcessBtfTurnsASessionIntoAMaterial) {
  testing::TemporaryDirectory dir;
  const std::string session = (dir / "s").string(), out = (dir / "m").string(), gt = (dir / "gt").string();
  ASSERT_EQ(Mesocap("-q simulate --scene flat --rig tiny --plan btf --out " + session).exit_code, 0);
  const CommandResult r =
      Mesocap("-q process btf --session " + session + " --out " + out + " --texture-size 8 --full --max-error 1e-3");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const formats::MaterialManifest m = formats::ReadMaterialManifest(out);
  EXPECT_TRUE(m.full_btf && m.factored_btf && m.ambient && m.calibration);
  const auto report = formats::ReadErrorReport(out, m);
  EXPECT_EQ(report["btf_assembly"]["measured_pairs"], 32);
  EXPECT_EQ(report["btf_assembly"]["interpolated_pairs"], 32);
  ASSERT_EQ(Mesocap("-q groundtruth --scene flat --rig tiny --texture-size 8 --out " + gt).exit_code, 0);
  const auto e = nlohmann::json::parse(Mesocap("eval btf --json --truth " + gt + " --estimate " + out).out);
  EXPECT_GT(e["overall"]["psnr_db"].get<double>(), 30.0) << e.dump();
  // The pairs the tiny rig captured and those it interpolated, apart (the
  // tiny rig resolves 8 x 8 texels in every view).
  EXPECT_EQ(e["captured"]["pairs"], 32) << e.dump();
  EXPECT_EQ(e["interpolated"]["pairs"], 32) << e.dump();
  EXPECT_EQ(e["unresolved"]["pairs"], 0) << e.dump();
  EXPECT_GT(e["captured"]["psnr_db"].get<double>(), 30.0) << e.dump();
  // Against a package without the record (the truth itself): no split.
  const auto self = nlohmann::json::parse(Mesocap("eval btf --json --truth " + gt + " --estimate " + gt).out);
  EXPECT_TRUE(self["captured"].is_null()) << self.dump();

  // Without --full the assembled views go through a scratch package that is
  // gone afterwards; the factors are the same as with them kept.
  const std::string compact = (dir / "m-compact").string();
  ASSERT_EQ(Mesocap("-q process btf --session " + session + " --out " + compact + " --texture-size 8 --max-error 1e-3")
                .exit_code,
            0);
  const formats::MaterialManifest mc = formats::ReadMaterialManifest(compact);
  EXPECT_TRUE(!mc.full_btf && mc.factored_btf && mc.ambient);
  const core::FactoredBtf with_full = formats::ReadFactoredBtf(out, m), without = formats::ReadFactoredBtf(compact, mc);
  ASSERT_EQ(with_full.rank(), without.rank());
  for (int k = 0; k < with_full.rank(); ++k) {
    for (std::size_t i = 0; i < with_full.rows[k].size(); ++i)
      ASSERT_EQ(with_full.rows[k].data()[i], without.rows[k].data()[i]);
  }
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().filename().string().find("assembled"), std::string::npos) << entry.path();
  }

  // The cameras' gain comes from the calibration's radiometry: without it (a
  // version 1 calibration) `process btf` is one error line naming the file
  // and the camera and suggesting --gain, and writes nothing; --gain G
  // supplies it for all cameras (here the simulated cameras' true gain,
  // which the session's calibration records).
  nlohmann::json calibration =
      nlohmann::json::parse(std::ifstream(std::filesystem::path(session) / "calibration.json"));
  ASSERT_EQ(calibration["version"], 2);
  const double gain = calibration["cameras"][0]["radiometry"]["signal_per_radiance_second"];
  EXPECT_EQ(calibration["cameras"][1]["radiometry"]["signal_per_radiance_second"], gain);
  calibration["version"] = 1;
  for (auto& camera : calibration["cameras"]) camera.erase("radiometry");
  const std::string v1 = (dir / "v1-calibration.json").string();
  std::ofstream(v1) << calibration.dump(1);

  const std::string args =
      "process btf --session " + session + " --calibration " + v1 + " --texture-size 4 --max-error 1e-4 --out ";
  const CommandResult no_gain = Mesocap(args + (dir / "no-gain").string());
  EXPECT_EQ(no_gain.exit_code, 1);
  EXPECT_EQ(no_gain.err.find('\n'), no_gain.err.size() - 1) << "more than one line: " << no_gain.err;
  EXPECT_NE(no_gain.err.find("v1-calibration.json: camera cam0 has no radiometry"), std::string::npos) << no_gain.err;
  EXPECT_NE(no_gain.err.find("--gain"), std::string::npos) << no_gain.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "no-gain"));

  const auto gain_text = [](double g) {
    std::ostringstream text;
    text << std::setprecision(17) << g;
    return text.str();
  };
  const std::string g1 = (dir / "g1").string(), g2 = (dir / "g2").string();
  const CommandResult r1 = Mesocap("-q " + args + g1 + " --full --gain " + gain_text(gain));
  ASSERT_EQ(r1.exit_code, 0) << r1.err;
  // --gain also overrides a calibration that has radiometry: twice the gain
  // halves every BTF value (the SVD factors scale alike; each package is
  // within 1e-4 of its full BTF).
  const CommandResult r2 = Mesocap("-q process btf --session " + session + " --texture-size 4 --max-error 1e-4 --out " +
                                   g2 + " --gain " + gain_text(2 * gain));
  ASSERT_EQ(r2.exit_code, 0) << r2.err;
  const auto scaled = nlohmann::json::parse(Mesocap("eval btf --json --truth " + g1 + " --estimate " + g2).out);
  EXPECT_NEAR(scaled["overall"]["relative_rms"].get<double>(), 0.5, 1e-3) << scaled.dump();
  EXPECT_NE(Mesocap("process btf --help").out.find("overriding"), std::string::npos);

  std::filesystem::remove(std::filesystem::path(session) / "btf" / "t1_a0_l1_cam0.png");
  const CommandResult missing = Mesocap("process btf --session " + session + " --out " + (dir / "m2").string());
  EXPECT_EQ(missing.exit_code, 1);
  EXPECT_NE(missing.err.find("t1_a0_l1_cam0.png: missing BTF image"), std::string::npos) << missing.err;
  EXPECT_FALSE(std::filesystem::exists(dir / "m2"));
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().filename().string().find("m2"), std::string::npos) << entry.path();
  }
}

}  // namespace
}  // namespace mesocap
