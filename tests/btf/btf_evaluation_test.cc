// BTF error figures against hand-computed values.
#include "btf/btf_evaluation.h"

#include <gtest/gtest.h>

#include <cmath>

#include "core/error.h"

namespace mesocap::btf {
namespace {

TEST(BtfEvaluation, RelativeRmsAndPsnrByPolarAngle) {
  // grid2x2: views at theta 22.5 and 67.5 degrees.
  const core::SamplingSet views = core::SamplingSet::Named("grid2x2");
  BtfErrorAccumulator errors(views);
  const core::Image truth(4, 4, 3, 1.0f);
  for (int v = 0; v < 4; ++v) {
    // Views 0, 1 (22.5 deg) off by 1%, views 2, 3 (67.5 deg) by 10%.
    errors.Add(v, truth, core::Image(4, 4, 3, v < 2 ? 1.01f : 1.1f));
  }
  const auto bands = errors.ByPolarAngle();
  ASSERT_EQ(bands.size(), 2u);
  EXPECT_EQ(bands[0].theta_min_deg, 15.0);
  EXPECT_EQ(bands[0].theta_max_deg, 30.0);
  EXPECT_NEAR(bands[0].figures.relative_rms, 0.01, 1e-6);
  EXPECT_NEAR(bands[0].figures.psnr_db, 40.0, 1e-4);  // peak 1, MSE 1e-4
  EXPECT_EQ(bands[1].theta_min_deg, 60.0);
  EXPECT_NEAR(bands[1].figures.relative_rms, 0.1, 1e-6);
  EXPECT_NEAR(bands[1].figures.psnr_db, 20.0, 1e-4);
  EXPECT_NEAR(errors.Overall().relative_rms, std::sqrt((1e-4 + 1e-2) / 2), 1e-6);
  EXPECT_NEAR(errors.Overall(60.0).psnr_db, 40.0, 1e-4) << "only the views up to 60 degrees";

  const auto j = ToJson(errors, 4);
  EXPECT_EQ(j["rank"], 4);
  EXPECT_NEAR(j["overall"]["relative_rms"].get<double>(), errors.Overall().relative_rms, 1e-12);
  EXPECT_EQ(j["by_polar_angle"][1]["theta_min_deg"], 60.0);
  EXPECT_TRUE(ToJson(errors, std::nullopt)["rank"].is_null());
}

TEST(BtfEvaluation, ExactEstimateHasInfinitePsnrAndNullInJson) {
  BtfErrorAccumulator errors(core::SamplingSet::Named("grid1x1"));
  errors.Add(0, core::Image(2, 2, 3, 0.5f), core::Image(2, 2, 3, 0.5f));
  EXPECT_TRUE(std::isinf(errors.Overall().psnr_db));
  EXPECT_EQ(errors.Overall().relative_rms, 0.0);
  EXPECT_TRUE(ToJson(errors, 1)["overall"]["psnr_db"].is_null());
  EXPECT_THROW(errors.Add(0, core::Image(2, 2, 3), core::Image(2, 3, 3)), core::Error);
}

}  // namespace
}  // namespace mesocap::btf
