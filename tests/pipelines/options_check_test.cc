// Each job's options refuse bad values before anything is read, with an
// error that names the option; good options pass.
#include <gtest/gtest.h>

#include <string>

#include "core/error.h"
#include "pipelines/compress.h"
#include "pipelines/export_bonn.h"
#include "pipelines/ground_truth.h"
#include "pipelines/import_bonn.h"
#include "pipelines/process_btf.h"
#include "pipelines/process_mdf.h"

namespace mesocap::pipelines {
namespace {

// Check()'s message, and the same message with the job's prefix from Run.
template <typename Options, typename Run>
void ExpectRefused(const Options& options, Run run, const std::string& job, const std::string& names) {
  const core::CheckResult problem = options.Check();
  EXPECT_NE(problem.find(names), std::string::npos) << problem;
  try {
    run(options);
    ADD_FAILURE() << job << " ran with bad options";
  } catch (const core::Error& e) {
    EXPECT_EQ(std::string(e.what()), job + ": " + problem);
  }
}

TEST(GroundTruthOptions, Check) {
  GroundTruthOptions o;
  o.out = "out";
  EXPECT_EQ(o.Check(), "");
  o.texture_size = 0;
  ExpectRefused(o, RunGroundTruth, "groundtruth", "texture_size");
  o.texture_size = 16;
  o.out.clear();
  ExpectRefused(o, RunGroundTruth, "groundtruth", "out");
}

TEST(ProcessMdfOptions, Check) {
  ProcessMdfOptions o;
  o.session = "session";
  o.calibration = "calibration.json";
  o.out = "out";
  EXPECT_EQ(o.Check(), "");
  o.calibration.clear();  // the one the session names
  EXPECT_EQ(o.Check(), "");
  o.processing.texture_size = 0;
  ExpectRefused(o, RunProcessMdf, "process mdf", "texture_size");
}

TEST(ProcessBtfOptions, Check) {
  ProcessBtfOptions o;
  o.session = "session";
  o.out = "out";
  EXPECT_EQ(o.Check(), "");  // the calibration may come from the session
  o.texture_size = -1;
  ExpectRefused(o, RunProcessBtf, "process btf", "texture_size");
  o.texture_size = 8;
  o.gain = -2;
  ExpectRefused(o, RunProcessBtf, "process btf", "gain");
  o.gain = 0;
  o.compression.rank = 1000;
  ExpectRefused(o, RunProcessBtf, "process btf", "rank");
}

TEST(CompressOptions, Check) {
  CompressOptions o;
  o.in = "in";
  o.out = "out";
  EXPECT_EQ(o.Check(), "");
  o.in.clear();
  ExpectRefused(o, RunCompress, "compress", "in");
  o.in = "in";
  o.compression.max_relative_error = -1;
  ExpectRefused(o, RunCompress, "compress", "error");
}

TEST(ExportBonnOptions, Check) {
  ExportBonnOptions o;
  o.in = "in";
  o.out = "out.dfmf";
  EXPECT_EQ(o.Check(), "");
  o.scale = 0;
  ExpectRefused(o, RunExportBonn, "export bonn", "scale");
  o.scale = 1;
  o.scalar = bonn::BonnScalar::kDouble;
  ExpectRefused(o, RunExportBonn, "export bonn", "half or float");
}

TEST(ImportBonnOptions, Check) {
  ImportBonnOptions o;
  o.in = "in.dfmf";
  o.out = "out";
  ExpectRefused(o, RunImportBonn, "import bonn", "d_max_mm");  // the Bonn forms carry no depth: required
  o.d_max_mm = 1.5;
  EXPECT_EQ(o.Check(), "");
  o.width_mm = -3;
  ExpectRefused(o, RunImportBonn, "import bonn", "width_mm");
  o.width_mm = 0;
  o.out.clear();
  ExpectRefused(o, RunImportBonn, "import bonn", "out");
}

}  // namespace
}  // namespace mesocap::pipelines
