// `mesocap eval btf --truth T --estimate E [--json]`: prints the figures of
// the BTF evaluation (pipelines/evaluate_btf.h) as a table or one JSON object.
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "pipelines/evaluate_btf.h"

namespace mesocap {
namespace {

struct EvalBtfCommandOptions {
  pipelines::EvaluateBtfOptions evaluation;
  bool json = false;
};

// A figure of the evaluation's JSON, where null stands for infinity.
double Figure(const nlohmann::json& value) {
  return value.is_null() ? std::numeric_limits<double>::infinity() : value.get<double>();
}

void PrintPairKinds(const nlohmann::json& result) {
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
}

void PrintTable(const EvalBtfCommandOptions& o, const nlohmann::json& result) {
  const std::string rank = result["rank"].is_null() ? "" : ", rank " + std::to_string(result["rank"].get<int>());
  std::printf("BTF (%s%s) against %s\n", result["form"].get<std::string>().c_str(), rank.c_str(),
              o.evaluation.truth.string().c_str());
  std::printf("  overall: PSNR %.2f dB, relative RMS %.4g (peak %.4g)\n", Figure(result["overall"]["psnr_db"]),
              Figure(result["overall"]["relative_rms"]), result["peak"].get<double>());
  for (const nlohmann::json& b : result["by_polar_angle"]) {
    std::printf("  view theta %4.1f-%4.1f deg: PSNR %.2f dB, relative RMS %.4g\n", b["theta_min_deg"].get<double>(),
                b["theta_max_deg"].get<double>(), Figure(b["psnr_db"]), Figure(b["relative_rms"]));
  }
  if (!result["captured"].is_null()) {
    PrintPairKinds(result);
  } else {
    std::printf("  (the estimate records no captured pairs: no split into captured and interpolated)\n");
  }
  if (result.contains("ambient")) {
    std::printf("  ambient term: relative RMS %.4g\n", result["ambient"]["relative_rms"].get<double>());
  }
}

void RunEvalBtf(const EvalBtfCommandOptions& o) {
  const nlohmann::json result = pipelines::EvaluateBtf(o.evaluation);
  if (o.json) {
    std::printf("%s\n", result.dump().c_str());
  } else {
    PrintTable(o, result);
  }
}

}  // namespace

void RegisterEvalBtfCommand(CLI::App& app) {
  auto o = std::make_shared<EvalBtfCommandOptions>();
  CLI::App* eval = GroupCommand(app, "eval", "Compare a measured material with ground truth");
  CLI::App* sub = eval->add_subcommand("btf", HelpText("eval_btf"));
  sub->add_option("--truth", o->evaluation.truth, "material package with the true full BTF (mesocap groundtruth)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_option("--estimate", o->evaluation.estimate,
                  "material package to evaluate (factored BTF if present, else full)")
      ->required()
      ->check(CLI::ExistingDirectory);
  sub->add_flag("--json", o->json, "print one JSON object");
  sub->callback([o] { RunEvalBtf(*o); });
}

}  // namespace mesocap
