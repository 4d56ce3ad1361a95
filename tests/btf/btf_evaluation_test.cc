// BTF error figures against hand-computed values.
#include "btf/btf_evaluation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/error.h"

namespace mesocap::btf {
namespace {

TEST(BtfEvaluation, RelativeRmsAndPsnrByPolarAngle) {
  // grid2x2: views at theta 22.5 and 67.5 degrees.
  const core::SamplingSet views = core::SamplingSet::Named("grid2x2");
  BtfErrorAccumulator errors(views, core::SamplingSet::Named("grid1x1"));
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
  BtfErrorAccumulator errors(core::SamplingSet::Named("grid1x1"), core::SamplingSet::Named("grid1x1"));
  errors.Add(0, core::Image(2, 2, 3, 0.5f), core::Image(2, 2, 3, 0.5f));
  EXPECT_TRUE(std::isinf(errors.Overall().psnr_db));
  EXPECT_EQ(errors.Overall().relative_rms, 0.0);
  EXPECT_TRUE(ToJson(errors, 1)["overall"]["psnr_db"].is_null());
  EXPECT_THROW(errors.Add(0, core::Image(2, 2, 3), core::Image(2, 3, 3)), core::Error);
}

TEST(BtfEvaluation, CapturedInterpolatedAndUnresolvedPairsApart) {
  // grid2x2 views (theta 22.5, 22.5, 67.5, 67.5 deg) and lights; 2 x 2
  // texels a light slice. View 3 is unresolved (0.5 pixels a texel).
  const core::SamplingSet views = core::SamplingSet::Named("grid2x2");
  const core::SamplingSet lights = core::SamplingSet::Named("grid2x2");
  BtfPairRecord record;
  record.captured = {
      {true, false, true, false}, {true, true, true, true}, {false, false, true, true}, {true, true, true, true}};
  record.pixels_per_texel = {3.0, 2.0, 1.0, 0.5};
  BtfErrorAccumulator errors(views, lights);
  const core::Image truth(2, 2 * lights.size(), 3, 1.0f);
  for (int v = 0; v < views.size(); ++v) {
    // Captured pairs off by 1 %, interpolated ones by 10 %, all of view 3 by 30 %.
    core::Image estimate(2, 2 * lights.size(), 3);
    for (int l = 0; l < lights.size(); ++l) {
      const float value = v == 3 ? 1.3f : record.captured[v][l] ? 1.01f : 1.1f;
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i)
          for (int c = 0; c < 3; ++c) estimate.pixel(i, l * 2 + j)[c] = value;
    }
    errors.Add(v, truth, estimate);
  }
  const auto j = ToJson(errors, std::nullopt, record);
  EXPECT_EQ(j["captured"]["pairs"], 8);
  EXPECT_NEAR(j["captured"]["relative_rms"].get<double>(), 0.01, 1e-6);
  EXPECT_NEAR(j["captured"]["psnr_db"].get<double>(), 40.0, 1e-4);  // the overall peak, 1
  EXPECT_EQ(j["interpolated"]["pairs"], 4);
  EXPECT_NEAR(j["interpolated"]["relative_rms"].get<double>(), 0.1, 1e-6);
  EXPECT_EQ(j["unresolved"]["pairs"], 4);
  EXPECT_EQ(j["unresolved"]["views"], 1);
  EXPECT_NEAR(j["unresolved"]["relative_rms"].get<double>(), 0.3, 1e-6);
  // Within 60 degrees: views 0 and 1 with lights 0 and 1 (22.5 deg), captured.
  EXPECT_EQ(j["captured_within_60deg"]["pairs"], 3);
  EXPECT_NEAR(j["overall"]["relative_rms"].get<double>(), std::sqrt((8 * 1e-4 + 4 * 1e-2 + 4 * 0.09) / 16), 1e-6);
  // Without a record the four are there, null.
  const auto bare = ToJson(errors, std::nullopt);
  for (const char* kind : {"captured", "interpolated", "unresolved", "captured_within_60deg"}) {
    EXPECT_TRUE(bare[kind].is_null()) << kind;
  }
}

TEST(BtfEvaluation, APairRecordRoundTripsAndAMalformedOneNamesTheField) {
  const BtfPairRecord record{{{true, false}, {false, true}, {true, true}}, {1.5, 0.8, 2.0}};
  nlohmann::json object = {{"images", 4}};
  AddPairRecord(record, &object);
  const auto back = ReadPairRecord(object, "error_report.json", 3, 2);
  ASSERT_TRUE(back);
  EXPECT_EQ(back->captured, record.captured);
  EXPECT_EQ(back->pixels_per_texel, record.pixels_per_texel);
  EXPECT_FALSE(ReadPairRecord({{"images", 4}}, "error_report.json", 3, 2)) << "no record: none";
  const auto error_of = [&](const nlohmann::json& o, int views, int lights) -> std::string {
    try {
      ReadPairRecord(o, "error_report.json", views, lights);
    } catch (const core::FormatError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(error_of(object, 4, 2).find("btf_assembly.captured"), std::string::npos) << "sized for other views";
  EXPECT_NE(error_of(object, 3, 3).find("captured[0]"), std::string::npos) << "sized for other lights";
  nlohmann::json bad = object;
  bad["pixels_per_texel"][1] = "wide";
  EXPECT_NE(error_of(bad, 3, 2).find("pixels_per_texel[1]"), std::string::npos);
  bad = object;
  bad["captured"][2][0] = 1;
  EXPECT_NE(error_of(bad, 3, 2).find("error_report.json"), std::string::npos);
}

}  // namespace
}  // namespace mesocap::btf
