// The paper rig's BTF end to end on the user's path, reduced to one turntable
// and one light-arc angle (8 cameras at 1024 x 768 under 8 lamps): `simulate
// --plan btf`, `groundtruth`, `process btf` at 128 x 128 texels, `eval btf`.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <nlohmann/json.hpp>
#include <string>

#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"
#include "tests/common/mesocap_command.h"
#include "tests/common/one_sweep_rig.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

using testing::CommandResult;
using testing::Mesocap;

TEST(PaperRigBtf, OnePositionMeetsThePsnrAndMemoryGoals) {
  testing::TemporaryDirectory dir;
  const std::string rig = testing::WriteRig(dir / "paper-one-position.json", testing::OnePositionRig("paper"));
  const std::string session = (dir / "s").string(), truth = (dir / "gt").string(), material = (dir / "m").string();

  // The simulator keeps one turntable angle's first hits for all its lamps,
  // so one position's peak is the whole session's.
  ASSERT_EQ(Mesocap("-q simulate --scene weave --rig " + rig + " --plan btf --out " + session).exit_code, 0);
  rusage usage{};
  ASSERT_EQ(getrusage(RUSAGE_CHILDREN, &usage), 0);
  const double peak_gb = usage.ru_maxrss * 1024.0 / 1e9;
  EXPECT_GT(peak_gb, 0.5) << "simulate's peak resident memory was not measured";
  EXPECT_LT(peak_gb, 4.0) << "simulate's peak resident memory on the paper rig";

  ASSERT_EQ(Mesocap("-q groundtruth --scene weave --rig " + rig + " --texture-size 128 --out " + truth).exit_code, 0);
  const CommandResult processed =
      Mesocap("-q process btf --session " + session + " --texture-size 128 --out " + material);
  ASSERT_EQ(processed.exit_code, 0) << processed.err;

  // The default budget (1 %) is met below full rank.
  const formats::MaterialManifest m = formats::ReadMaterialManifest(material);
  const auto compression = formats::ReadErrorReport(material, m)["btf_compression"];
  EXPECT_LE(compression["measured_relative_rms"].get<double>(), 0.01) << compression.dump();
  EXPECT_LT(compression["rank"].get<int>(), compression["max_rank"].get<int>()) << compression.dump();

  const CommandResult eval = Mesocap("eval btf --json --truth " + truth + " --estimate " + material);
  ASSERT_EQ(eval.exit_code, 0) << eval.err;
  const auto e = nlohmann::json::parse(eval.out);
  // The rig captures every pair of its own directions: nothing interpolated.
  // At 128 x 128 texels (2.8 pixels a texel head-on) the two cameras at 5.6
  // and 16.9 degrees of elevation see a texel under one pixel: their pairs
  // count as unresolved, apart from the captured ones.
  EXPECT_EQ(e["interpolated"]["pairs"], 0) << e.dump();
  EXPECT_EQ(e["captured"]["pairs"].get<int>() + e["unresolved"]["pairs"].get<int>(), 64) << e.dump();
  EXPECT_GE(e["captured_within_60deg"]["psnr_db"].get<double>(), 35.0) << e.dump();
}

}  // namespace
}  // namespace mesocap
