// Each subcommand of the `mesocap` CLI lives in its own file and registers
// itself on the application with one function declared here.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace mesocap {

void RegisterInfoCommand(CLI::App& app);
void RegisterGroundTruthCommand(CLI::App& app);
void RegisterSimulateCommand(CLI::App& app);
void RegisterCompressCommand(CLI::App& app);
void RegisterEvalBtfCommand(CLI::App& app);     // `eval btf`
void RegisterProcessBtfCommand(CLI::App& app);  // `process btf`
void RegisterProcessMdfCommand(CLI::App& app);  // `process mdf`
void RegisterEvalMdfCommand(CLI::App& app);     // `eval mdf`
void RegisterExportBonnCommand(CLI::App& app);  // `export bonn`
void RegisterImportBonnCommand(CLI::App& app);  // `import bonn`

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
void RegisterRenderCommand(CLI::App& app);
void RegisterCompareCommand(CLI::App& app);
void RegisterViewCommand(CLI::App& app);
void RegisterVerifyCommand(CLI::App& app);

}  // namespace mesocap
