// `mesocap eval mdf --truth T --estimate E [--json] [--out FILE]`: the error
// table of a measured MDF against the exact one (mdf/mdf_evaluation.h).
#include <cstdio>
#include <filesystem>
#include <memory>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_field_reader.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"
#include "mdf/mdf_evaluation.h"

namespace mesocap {
namespace {

struct EvalMdfOptions {
  std::filesystem::path truth;
  std::filesystem::path estimate;
  std::filesystem::path out;
  bool json = false;
  bool inside_sample_only = false;
  bool replace = false;
};

bool IsMdfErrorReport(const std::filesystem::path& file) {
  return core::JsonFileHolds(file, [](const nlohmann::json& doc) {
    return doc.is_object() && doc.contains("overall") && doc.contains("by_polar_angle");
  });
}

void RunEvalMdf(const EvalMdfOptions& o) {
  if (!o.out.empty()) {
    ExpectReplaceableFile(o.out, o.replace, "an MDF error report (JSON with \"overall\" and \"by_polar_angle\")",
                          IsMdfErrorReport, {o.truth, o.estimate});
  }
  const formats::MaterialManifest truth_manifest = formats::ReadMaterialManifest(o.truth);
  const formats::MaterialManifest estimate_manifest = formats::ReadMaterialManifest(o.estimate);
  const formats::MaterialDescription &t = truth_manifest.description, &e = estimate_manifest.description;
  // `field` as "ESTIMATE here, TRUTH in the truth's".
  const auto mismatch = [&](const char* field, const std::string& here, const std::string& there) {
    throw core::FormatError(o.estimate / "manifest.json", field,
                            here + " here, " + there + " in the truth's (" + (o.truth / "manifest.json").string() +
                                "); evaluate against a ground truth of the estimate's grid (mesocap groundtruth "
                                "--texture-size, --views)");
  };
  const auto grid = [](int w, int h) { return std::to_string(w) + "x" + std::to_string(h); };
  const auto mm = [](const Eigen::Vector2d& s) {
    return core::Fixed(s.x(), 3) + " x " + core::Fixed(s.y(), 3) + " mm";
  };
  if (t.width != e.width || t.height != e.height) {
    mismatch("texture_size", grid(e.width, e.height), grid(t.width, t.height));
  }
  if ((e.physical_size_mm - t.physical_size_mm).norm() > 1e-6 * t.physical_size_mm.norm()) {
    mismatch("physical_size_mm", mm(e.physical_size_mm), mm(t.physical_size_mm));
  }
  // About 0.2 arc seconds: two packages made from one rig description.
  if (!t.view_directions.SameDirectionsAs(e.view_directions, 1e-6)) {
    mismatch("view_directions", std::to_string(e.view_directions.size()) + " directions",
             std::to_string(t.view_directions.size()) + " other directions");
  }
  const core::Mdf truth = formats::ReadMdf(o.truth, truth_manifest);
  const core::Mdf estimate = formats::ReadMdf(o.estimate, estimate_manifest);
  const auto& size = t.physical_size_mm;
  const mdf::MdfErrorTable table = mdf::EvaluateMdf(truth, estimate, size.x() / truth.width, o.inside_sample_only);
  const nlohmann::json json = ToJson(table);
  if (!o.out.empty()) core::WriteJsonFileAtomically(o.out, json);
  if (o.json) {
    std::printf("%s\n", json.dump(2).c_str());
  } else {
    std::printf("%s", mdf::FormatMdfErrorTable(table).c_str());
  }
}

}  // namespace

void RegisterEvalMdfCommand(CLI::App& app) {
  auto o = std::make_shared<EvalMdfOptions>();
  CLI::App* group = GroupCommand(app, "eval", "Compare processed material parts with ground truth");
  CLI::App* sub = group->add_subcommand("mdf", HelpText("eval_mdf"));
  sub->add_option("--truth", o->truth, "material package holding the true MDF (mesocap groundtruth)")->required();
  sub->add_option("--estimate", o->estimate, "material package holding the measured MDF")->required();
  sub->add_flag("--json", o->json, "print the table as one JSON object");
  sub->add_flag("--inside-sample-only", o->inside_sample_only,
                "leave out true hits behind the sample pocket's wall (outside the sample square), which the rig "
                "cannot see");
  sub->add_option("--out", o->out, "also write the JSON table to this file");
  sub->add_flag("--replace", o->replace, "replace an existing file at --out");
  sub->callback([o] { RunEvalMdf(*o); });
}

}  // namespace mesocap
