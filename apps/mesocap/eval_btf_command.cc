// `mesocap eval btf --truth T --estimate E [--json]`: the error of a material
// package's BTF (factored if it holds one, else full) against a true full BTF
// (`mesocap groundtruth`) on the same texture grid and direction sets,
// overall and by view polar angle; captured, interpolated and unresolved
// pairs apart when the estimate's error report records which are which
// (`process btf` does); and of its ambient term when both have one.
#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>

#include "apps/mesocap/command.h"
#include "btf/btf_compression.h"
#include "btf/btf_evaluation.h"
#include "core/error.h"
#include "formats/material_manifest.h"
#include "formats/material_package.h"
#include "formats/material_package_layout.h"
#include "formats/material_package_reader.h"

namespace mesocap {
namespace {

struct EvalBtfCommandOptions {
  std::filesystem::path truth;
  std::filesystem::path estimate;
  bool json = false;
};

// A figure of ToJson's, where null stands for infinity.
double Figure(const nlohmann::json& value) {
  return value.is_null() ? std::numeric_limits<double>::infinity() : value.get<double>();
}

bool SameDirections(const core::SamplingSet& a, const core::SamplingSet& b) {
  if (a.size() != b.size()) return false;
  for (int i = 0; i < a.size(); ++i) {
    if (a.direction(i).dot(b.direction(i)) < std::cos(1e-6)) return false;
  }
  return true;
}

void ExpectComparable(const EvalBtfCommandOptions& o, const formats::MaterialDescription& t,
                      const formats::MaterialDescription& e) {
  const auto mismatch = [&](const std::string& what) {
    throw core::Error(
        "eval btf: " + o.estimate.string() + " and " + o.truth.string() + " differ in " + what +
        "; evaluate against a ground truth on the estimate's grid (mesocap groundtruth --texture-size, --views, "
        "--lights)");
  };
  if (t.width != e.width || t.height != e.height) mismatch("texture size");
  if (!SameDirections(t.view_directions, e.view_directions)) mismatch("view directions");
  if (!SameDirections(t.light_directions, e.light_directions)) mismatch("light directions");
}

void RunEvalBtf(const EvalBtfCommandOptions& o) {
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
  std::optional<btf::BtfPairRecord> pairs;
  if (estimate.error_report) {
    const nlohmann::json report = formats::ReadErrorReport(o.estimate, estimate);
    if (report.is_object() && report.contains("btf_assembly")) {
      pairs = btf::ReadPairRecord(report["btf_assembly"], o.estimate / formats::kErrorReportFile,
                                  estimate.description.view_directions.size(),
                                  estimate.description.light_directions.size());
    }
  }
  for (int v = 0; v < truth.description.view_directions.size(); ++v) {
    const core::Image t = formats::ReadFullBtfView(o.truth, truth, v);
    errors.Add(v, t,
               factored ? btf::ReconstructBtfView(*factored, v) : formats::ReadFullBtfView(o.estimate, estimate, v));
  }
  nlohmann::json result = ToJson(errors, factored ? std::optional<int>(factored->rank()) : std::nullopt, pairs);
  result["form"] = factored ? "factored" : "full";
  if (truth.ambient && estimate.ambient) {
    const formats::AmbientTerm ta = formats::ReadAmbientTerm(o.truth, truth);
    const formats::AmbientTerm ea = formats::ReadAmbientTerm(o.estimate, estimate);
    // One "view" and one "light": the whole ambient image.
    btf::BtfErrorAccumulator ambient(core::SamplingSet::Named("grid1x1"), core::SamplingSet::Named("grid1x1"));
    ambient.Add(0, ta.values, ea.values);
    result["ambient"] = {{"relative_rms", ambient.Overall().relative_rms}, {"psnr_db", ambient.Overall().psnr_db}};
  }
  if (o.json) {
    std::printf("%s\n", result.dump().c_str());
    return;
  }
  const auto overall = errors.Overall();
  std::printf("BTF (%s%s) against %s\n", result["form"].get<std::string>().c_str(),
              factored ? (", rank " + std::to_string(factored->rank())).c_str() : "", o.truth.string().c_str());
  std::printf("  overall: PSNR %.2f dB, relative RMS %.4g (peak %.4g)\n", overall.psnr_db, overall.relative_rms,
              errors.peak());
  for (const auto& b : errors.ByPolarAngle()) {
    std::printf("  view theta %4.1f-%4.1f deg: PSNR %.2f dB, relative RMS %.4g\n", b.theta_min_deg, b.theta_max_deg,
                b.figures.psnr_db, b.figures.relative_rms);
  }
  if (pairs) {
    for (const auto& [kind, label] : {std::pair{"captured", "captured"}, std::pair{"interpolated", "interpolated"},
                                      std::pair{"unresolved", "unresolved"},
                                      std::pair{"captured_within_60deg", "captured, view and light within 60 deg,"}}) {
      const nlohmann::json& k = result[kind];
      if (k["pairs"].get<int>() == 0) {
        std::printf("  %s pairs: none\n", label);
      } else {
        std::printf("  %s pairs (%d): PSNR %.2f dB, relative RMS %.4g\n", label, k["pairs"].get<int>(),
                    Figure(k["psnr_db"]), Figure(k["relative_rms"]));
      }
    }
    if (result["unresolved"]["views"].get<int>() > 0) {
      std::printf("  (unresolved: the %d views whose texels are finer than a camera pixel)\n",
                  result["unresolved"]["views"].get<int>());
    }
  } else {
    std::printf("  (the estimate records no captured pairs: no split into captured and interpolated)\n");
  }
  if (result.contains("ambient")) {
    std::printf("  ambient term: relative RMS %.4g\n", result["ambient"]["relative_rms"].get<double>());
  }
}

}  // namespace

void RegisterEvalBtfCommand(CLI::App& app) {
  auto o = std::make_shared<EvalBtfCommandOptions>();
  CLI::App* eval = GroupCommand(app, "eval", "Compare a measured material with ground truth");
  CLI::App* sub = eval->add_subcommand(
      "btf",
      "Error of a material's BTF (and ambient term) against a true BTF\n\n"
      "The true full BTF must be on the same grid. PSNR and relative RMS overall and by view polar angle (15 "
      "degree bands), and, for a package process btf made, apart for the pairs an image captured, those "
      "interpolated from a view's captured lights, the views whose texels are finer than a camera pixel "
      "(unresolved), and the captured pairs with view and light within 60 degrees. --json prints overall, "
      "by_polar_angle, rank, captured, interpolated, unresolved, captured_within_60deg (null without the "
      "record).");
  sub->add_option("--truth", o->truth, "material package with the true full BTF (mesocap groundtruth)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--estimate", o->estimate, "material package to evaluate (factored BTF if present, else full)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_flag("--json", o->json, "print one JSON object");
  sub->callback([o] { RunEvalBtf(*o); });
}

}  // namespace mesocap
