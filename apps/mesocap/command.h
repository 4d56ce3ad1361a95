// Each subcommand of the `mesocap` CLI lives in its own file and registers
// itself on the application with one function declared here.
#pragma once

#include <CLI/CLI.hpp>
#include <string>

namespace mesocap {

// Global flags shared by every subcommand.
struct GlobalOptions {
  int verbosity = 0;  // -v raises it, -q lowers it
};

void RegisterInfoCommand(CLI::App& app);
void RegisterGroundTruthCommand(CLI::App& app);
void RegisterSimulateCommand(CLI::App& app);
void RegisterCompressCommand(CLI::App& app);
void RegisterEvalBtfCommand(CLI::App& app);
void RegisterProcessBtfCommand(CLI::App& app);

// The group subcommand `name` (`eval`, `process`), created by whichever file
// registers first, so each file adds its own `eval X` without the others.
inline CLI::App* SubcommandGroup(CLI::App& app, const std::string& name, const std::string& description) {
  try {
    return app.get_subcommand(name);
  } catch (const CLI::OptionNotFound&) {
    CLI::App* group = app.add_subcommand(name, description);
    group->require_subcommand(1);
    return group;
  }
}

}  // namespace mesocap
