// The ambient term (Sec. 4.2) by quadrature against the simulated rig's exact
// one, against the analytic flat Lambertian answer, and its convergence.
#include "btf/ambient_term.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/ground_truth.h"
#include "sim/mesostructure_scene.h"

namespace mesocap::btf {
namespace {

core::FullBtf TrueBtf(const std::string& scene_name, const sim::GroundTruthOptions& gt) {
  const auto scene = sim::MakeBuiltinScene(scene_name);
  return sim::RenderTrueBtf(*scene, gt);
}

sim::GroundTruthOptions Options(const std::string& views, const std::string& lights) {
  sim::GroundTruthOptions gt;
  gt.texels.width = gt.texels.height = 8;
  gt.texels.sample_size_mm = 12.0;
  gt.views = core::SamplingSet::Named(views);
  gt.lights = core::SamplingSet::Named(lights);
  return gt;
}

double RelativeRms(const core::Image& a, const core::Image& b) {
  double e = 0, t = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    e += (a.data()[i] - b.data()[i]) * (a.data()[i] - b.data()[i]);
    t += b.data()[i] * b.data()[i];
  }
  return std::sqrt(e / t);
}

TEST(AmbientTerm, MatchesTheSimulatedRigsExactAmbientTerm) {
  const auto gt = Options("grid6x3", "paper12x8");
  const core::FullBtf btf = TrueBtf("weave", gt);
  const formats::AmbientTerm la = ComputeAmbientTerm(btf);
  formats::AmbientTerm truth = MakeAmbientTerm(8, 8, gt.views);
  for (int v = 0; v < gt.views.size(); ++v) sim::AccumulateAmbientTerm(btf.view_images[v], gt.lights, v, &truth);
  EXPECT_LT(RelativeRms(la.values, truth.values), 1e-6);
}

TEST(AmbientTerm, FlatLambertianSampleHasItsAlbedo) {
  // La = albedo / pi * sum_l cos(theta_l) w_l; the sum is pi up to the
  // midpoint quadrature's error of the cosine on 12 bands (~0.5%).
  const formats::AmbientTerm la = ComputeAmbientTerm(TrueBtf("flat", Options("grid4x2", "grid24x12")));
  for (int v = 0; v < 8; ++v)
    for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(la.at(3, 5, v)[ch], 0.5, 0.005) << "view " << v;
}

TEST(AmbientTerm, QuadratureOnThePaperLightSetConvergesToADenseOne) {
  // Weave: shadows and grazing falloff make La vary with view; the paper's
  // 12 x 8 light set against a 3x denser one.
  const core::FullBtf sparse = TrueBtf("weave", Options("grid4x2", "paper12x8"));
  const core::FullBtf dense = TrueBtf("weave", Options("grid4x2", "grid36x24"));
  const double error = RelativeRms(ComputeAmbientTerm(sparse).values, ComputeAmbientTerm(dense).values);
  EXPECT_LT(error, 0.03);
  RecordProperty("relative_rms_paper12x8_vs_grid36x24", std::to_string(error));
}

TEST(AmbientTerm, RejectsAViewImageOfTheWrongSize) {
  formats::AmbientTerm la = MakeAmbientTerm(4, 4, core::SamplingSet::Named("grid2x1"));
  EXPECT_THROW(AddAmbientView(core::Image(4, 8, 3), core::SamplingSet::Named("grid3x1"), 0, &la), core::Error);
  EXPECT_THROW(AddAmbientView(core::Image(4, 12, 3), core::SamplingSet::Named("grid3x1"), 2, &la), core::Error);
}

}  // namespace
}  // namespace mesocap::btf
