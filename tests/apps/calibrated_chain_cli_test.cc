// The whole chain without truth, as the README's main job runs it: a
// calibration session and a capture session on the tiny rig, `mesocap
// calibrate --session`, then `process mdf` and `process btf` with the
// estimated calibration, against the same processing with the simulator's
// true calibration. What the estimate may cost: MDF median and p95 within
// 10 %, coverage within 0.005, BTF PSNR within 0.5 dB. The texture is the 12
// x 12 texels (1 mm) the tiny rig's 128 x 96 cameras resolve at every view.
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/common/mesocap_command.h"

namespace mesocap {
namespace {

using testing::Mesocap;
using testing::TemporaryDirectory;
namespace fs = std::filesystem;

// Runs mesocap, expecting success; its JSON output, or null when it printed none.
nlohmann::json MesocapOk(const std::string& args) {
  const auto r = Mesocap(args);
  EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
  return r.exit_code == 0 && !r.out.empty() && r.out.front() == '{' ? nlohmann::json::parse(r.out) : nlohmann::json();
}

struct Figures {
  double median_mm = 0, p95_mm = 0, coverage = 0, psnr_db = 0;
};

Figures Process(const fs::path& dir, const fs::path& calibration, const std::string& name) {
  const std::string session = (dir / "S").string(), truth = (dir / "T").string();
  const std::string mdf = (dir / ("mdf-" + name)).string(), btf = (dir / ("btf-" + name)).string();
  MesocapOk("-q process mdf --session " + session + " --calibration " + calibration.string() +
            " --texture-size 12 --out " + mdf);
  MesocapOk("-q process btf --session " + session + " --calibration " + calibration.string() +
            " --texture-size 12 --out " + btf);
  const nlohmann::json m = MesocapOk("eval mdf --inside-sample-only --json --truth " + truth + " --estimate " + mdf);
  const nlohmann::json b = MesocapOk("eval btf --json --truth " + truth + " --estimate " + btf);
  if (m.is_null() || b.is_null()) return {};
  return {m["overall"]["median_mm"].get<double>(), m["overall"]["p95_mm"].get<double>(),
          m["overall"]["coverage"].get<double>(), b["overall"]["psnr_db"].get<double>()};
}

TEST(CalibratedChainCli, EstimatedCalibrationCostsLittleAgainstTheTrueOne) {
  TemporaryDirectory dir;
  MesocapOk("-q simulate --plan calibration --rig tiny --scene weave --out " + (dir / "C").string());
  MesocapOk("-q calibrate --session " + (dir / "C").string() + " --out " + (dir / "estimated.json").string());
  MesocapOk("-q simulate --rig tiny --scene weave --seed 1 --out " + (dir / "S").string());
  MesocapOk("-q groundtruth --rig tiny --scene weave --texture-size 12 --out " + (dir / "T").string());
  ASSERT_FALSE(HasFailure());
  // The capture session carries the simulator's true calibration.
  const Figures truth = Process(dir.path(), dir / "S" / "calibration.json", "true");
  const Figures estimate = Process(dir.path(), dir / "estimated.json", "estimated");
  ASSERT_FALSE(HasFailure());
  std::printf("true calibration: median %.4f p95 %.4f coverage %.4f psnr %.2f\n", truth.median_mm, truth.p95_mm,
              truth.coverage, truth.psnr_db);
  std::printf("estimated:        median %.4f p95 %.4f coverage %.4f psnr %.2f\n", estimate.median_mm, estimate.p95_mm,
              estimate.coverage, estimate.psnr_db);
  EXPECT_NEAR(estimate.median_mm, truth.median_mm, 0.1 * truth.median_mm);
  EXPECT_NEAR(estimate.p95_mm, truth.p95_mm, 0.1 * truth.p95_mm);
  EXPECT_NEAR(estimate.coverage, truth.coverage, 0.005);
  EXPECT_NEAR(estimate.psnr_db, truth.psnr_db, 0.5);
}

}  // namespace
}  // namespace mesocap
