#include "pipelines/evaluate_btf.h"

#include <optional>
#include <string>

#include "btf/btf_compression.h"
#include "btf/btf_evaluation.h"
#include "formats/material_manifest.h"
#include "formats/material_package.h"
#include "formats/material_package_layout.h"
#include "formats/material_package_reader.h"

namespace mesocap::pipelines {
namespace {

// Truth and estimate share a direction set when they agree to this (about
// 0.2 arc seconds): two packages made from one rig description.
constexpr double kSameDirection = 1e-6;

void ExpectComparable(const EvaluateBtfOptions& o, const formats::MaterialDescription& t,
                      const formats::MaterialDescription& e) {
  const auto mismatch = [&](const std::string& what) {
    throw core::Error(
        "eval btf: " + o.estimate.string() + " and " + o.truth.string() + " differ in " + what +
        "; evaluate against a ground truth on the estimate's grid (mesocap groundtruth --texture-size, --views, "
        "--lights)");
  };
  if (t.width != e.width || t.height != e.height) mismatch("texture size");
  if (!t.view_directions.SameDirectionsAs(e.view_directions, kSameDirection)) mismatch("view directions");
  if (!t.light_directions.SameDirectionsAs(e.light_directions, kSameDirection)) mismatch("light directions");
}

// Which pairs an image captured, as `process btf` recorded them.
std::optional<btf::BtfPairRecord> PairRecord(const EvaluateBtfOptions& o, const formats::MaterialManifest& estimate) {
  if (!estimate.error_report) return std::nullopt;
  const nlohmann::json report = formats::ReadErrorReport(o.estimate, estimate);
  if (!report.is_object() || !report.contains("btf_assembly")) return std::nullopt;
  return btf::ReadPairRecord(report["btf_assembly"], o.estimate / formats::kErrorReportFile,
                             estimate.description.view_directions.size(), estimate.description.light_directions.size());
}

// One "view" and one "light": the whole ambient image.
nlohmann::json AmbientFigures(const EvaluateBtfOptions& o, const formats::MaterialManifest& truth,
                              const formats::MaterialManifest& estimate) {
  const formats::AmbientTerm ta = formats::ReadAmbientTerm(o.truth, truth);
  const formats::AmbientTerm ea = formats::ReadAmbientTerm(o.estimate, estimate);
  btf::BtfErrorAccumulator ambient(core::SamplingSet::Named("grid1x1"), core::SamplingSet::Named("grid1x1"));
  ambient.Add(0, ta.values, ea.values);
  return {{"relative_rms", ambient.Overall().relative_rms}, {"psnr_db", ambient.Overall().psnr_db}};
}

}  // namespace

core::CheckResult EvaluateBtfOptions::Check() const {
  if (truth.empty()) return "--truth: a material package with the true full BTF is needed";
  if (estimate.empty()) return "--estimate: a material package to evaluate is needed";
  return "";
}

nlohmann::json EvaluateBtf(const EvaluateBtfOptions& o) {
  core::ThrowIfInvalid(o.Check(), "eval btf");
  const formats::MaterialManifest truth = formats::ReadMaterialManifest(o.truth);
  if (!truth.full_btf) throw core::Error("eval btf: the truth " + o.truth.string() + " holds no full BTF");
  const formats::MaterialManifest estimate = formats::ReadMaterialManifest(o.estimate);
  if (!estimate.full_btf && !estimate.factored_btf) {
    throw core::Error("eval btf: the estimate " + o.estimate.string() + " holds no BTF");
  }
  ExpectComparable(o, truth.description, estimate.description);

  std::optional<core::FactoredBtf> factored;
  if (estimate.factored_btf) factored = formats::ReadFactoredBtf(o.estimate, estimate);
  btf::BtfErrorAccumulator errors(truth.description.view_directions, truth.description.light_directions);
  for (int v = 0; v < truth.description.view_directions.size(); ++v) {
    const core::Image t = formats::ReadFullBtfView(o.truth, truth, v);
    errors.Add(v, t,
               factored ? btf::ReconstructBtfView(*factored, v) : formats::ReadFullBtfView(o.estimate, estimate, v));
  }
  nlohmann::json result =
      ToJson(errors, factored ? std::optional<int>(factored->rank()) : std::nullopt, PairRecord(o, estimate));
  result["form"] = factored ? "factored" : "full";
  if (truth.ambient && estimate.ambient) result["ambient"] = AmbientFigures(o, truth, estimate);
  return result;
}

}  // namespace mesocap::pipelines
