// The whole MDF pipeline of Sec. 3.2 on simulated scans against the exact
// MDF (sim/ground_truth.h).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>

#include "processing/mdf_evaluation.h"
#include "tests/processing/simulated_scan.h"

namespace mesocap::test {
namespace {

TEST(MdfPipelineTest, TinyBlocks) {
  ScanSetup setup;
  setup.scene = "blocks";
  setup.rig = "tiny";
  const ScanResult r = RunSimulatedScan(setup);
  const MdfErrorTable table = EvaluateMdf(r.truth, r.estimate, r.texel_mm);
  std::printf("%s", FormatMdfErrorTable(table).c_str());
}

}  // namespace
}  // namespace mesocap::test
namespace mesocap::test {
namespace {
TEST(MdfPipelineTest, Explore) {
  ScanSetup setup;
  setup.scene = std::getenv("SCENE") ? std::getenv("SCENE") : "blocks";
  setup.rig = "small";
  setup.turntable_indices = {0};
  setup.cameras = {0, 1, 2, 3};
  if (std::getenv("CAMS")) setup.cameras = {std::atoi(std::getenv("CAMS"))};
  if (std::getenv("RATIO")) setup.triangulation.max_depth_step_ratio = std::atof(std::getenv("RATIO"));
  if (std::getenv("STEP")) setup.triangulation.max_depth_step_texels = std::atof(std::getenv("STEP"));
  if (std::getenv("FILL")) setup.triangulation.fill_discontinuities = std::atoi(std::getenv("FILL"));
  const ScanResult r = RunSimulatedScan(setup);
  const MdfErrorTable table = EvaluateMdf(r.truth, r.estimate, r.texel_mm, true);
  std::printf("%s", FormatMdfErrorTable(table).c_str());
  const MdfErrorRow up60 = EvaluateMdfViews(r.truth, r.estimate, r.texel_mm, {0, 60, true});
  std::printf("up to 60: median %.3f p95 %.3f coverage %.4f\n", up60.median_texels, up60.p95_texels, up60.coverage);
}
}  // namespace
}  // namespace mesocap::test
namespace mesocap::test {
namespace {
TEST(MdfPipelineTest, Map) {
  ScanSetup setup;
  setup.scene = std::getenv("SCENE") ? std::getenv("SCENE") : "blocks";
  setup.rig = "small";
  setup.turntable_indices = {0};
  setup.cameras = {std::getenv("CAM") ? std::atoi(std::getenv("CAM")) : 1};
  setup.noise = true;
  const ScanResult r = RunSimulatedScan(setup);
  for (int v = 0; v < r.truth.view_count(); ++v) {
    if (std::isnan(r.truth.at(0, 0, v))) continue;
    std::printf("view %d theta %.1f phi %.1f\n", v, r.truth.views.angles(v).theta * 57.3, r.truth.views.angles(v).phi * 57.3);
    for (int j = 0; j < r.truth.height; ++j) {
      for (int i = 0; i < r.truth.width; ++i) {
        const float t = r.truth.at(i, j, v), e = r.estimate.at(i, j, v);
        char c = '.';
        if (std::isnan(e)) c = 'U';
        else if (std::abs(e - t) > 2 * r.texel_mm) c = 'X';
        else if (std::abs(e - t) > 0.5 * r.texel_mm) c = 'x';
        std::putchar(c);
      }
      std::printf("   ");
      for (int i = 0; i < r.truth.width; ++i) std::putchar('0' + std::min(9, static_cast<int>(r.truth.at(i, j, v) / 0.5)));
      std::putchar('\n');
    }
  }
}
}  // namespace
}  // namespace mesocap::test
