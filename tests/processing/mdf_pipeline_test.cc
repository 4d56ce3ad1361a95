// The whole MDF pipeline of Sec. 3.2 on simulated scans against the exact
// MDF (sim/ground_truth.h).
#include <gtest/gtest.h>

#include <cstdio>

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
