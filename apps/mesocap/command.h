// Each subcommand of the `mesocap` CLI lives in its own file and registers
// itself on the application with one function declared here.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"

namespace mesocap {

void RegisterInfoCommand(CLI::App& app);
void RegisterGroundTruthCommand(CLI::App& app);
void RegisterSimulateCommand(CLI::App& app);
void RegisterCompressCommand(CLI::App& app);
void RegisterEvalBtfCommand(CLI::App& app);       // `eval btf`
void RegisterProcessBtfCommand(CLI::App& app);    // `process btf`
void RegisterProcessMdfCommand(CLI::App& app);    // `process mdf`
void RegisterEvalMdfCommand(CLI::App& app);       // `eval mdf`
void RegisterExportBonnCommand(CLI::App& app);    // `export bonn`
void RegisterImportBonnCommand(CLI::App& app);    // `import bonn`
void RegisterRigCheckCommand(CLI::App& app);      // `rig check`, `devices`
void RegisterServeCamerasCommand(CLI::App& app);  // `sim serve-cameras`
void RegisterCalibrateCommand(CLI::App& app);     // `calibrate`, `calibrate camera`
void RegisterCaptureCommand(CLI::App& app);       // `capture submit|list|status|watch|...`

// The group command `name` ("process", "eval"), created on first use so that
// each of its subcommands registers itself independently.
inline CLI::App* GroupCommand(CLI::App& app, const std::string& name, const std::string& description) {
  try {
    return app.get_subcommand(name);
  } catch (const CLI::OptionNotFound&) {
    CLI::App* group = app.add_subcommand(name, description);
    group->require_subcommand(1);
    return group;
  }
}
// A numeric flag's check: "--d-max-mm: -1 is outside [1e-06, 10000]" (the
// option's name comes from CLI11), the range as the docs write it.
inline CLI::Validator InRange(double min, double max) {
  std::ostringstream written;
  written << "[" << min << ", " << max << "]";
  const std::string range = written.str();
  return CLI::Validator(
      [min, max, range](std::string& text) -> std::string {
        double value = 0.0;
        if (!CLI::detail::lexical_cast(text, value))
          return "expected a number in " + range + ", got " + core::Quoted(text);
        if (!(value >= min && value <= max)) return core::Cut(text) + " is outside " + range;
        return {};
      },
      "in " + range);
}

// The check that a flag's word (any case) is one of `names`; the help lists
// the words alone, where CLI11's own would also show the values they map to.
template <typename T>
CLI::CheckedTransformer NamedChoice(const std::map<std::string, T>& names) {
  std::string listed;
  for (const auto& entry : names) listed += (listed.empty() ? "" : ",") + entry.first;
  CLI::CheckedTransformer check(names, CLI::ignore_case);
  check.description("{" + listed + "}");
  return check;
}

// A subcommand's output file (an image, a report) is replaced only with
// --replace, only when it holds what the command writes (`kind`, which
// `holds_kind` recognises) and is none of the command's `inputs`; a killed
// run's temporary of it is removed first.
inline void ExpectReplaceableFile(const std::filesystem::path& out, bool replace, std::string kind,
                                  std::function<bool(const std::filesystem::path&)> holds_kind,
                                  std::vector<std::filesystem::path> inputs) {
  core::ExpectOutputFolder(out);
  core::RemoveStaleTemporariesOf(out);
  core::ExpectReplaceable(out, {replace, std::move(kind), std::move(holds_kind), std::move(inputs)});
}

void RegisterRenderCommand(CLI::App& app);
void RegisterCompareCommand(CLI::App& app);
void RegisterViewCommand(CLI::App& app);
void RegisterVerifyCommand(CLI::App& app);

}  // namespace mesocap
