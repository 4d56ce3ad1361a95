// Each subcommand of the `mesocap` CLI lives in its own file and registers
// itself on the application with one function declared here.
#pragma once

#include <CLI/CLI.hpp>

namespace mesocap {

// Global flags shared by every subcommand.
struct GlobalOptions {
  int verbosity = 0;  // -v raises it, -q lowers it
};

void RegisterInfoCommand(CLI::App& app);
void RegisterGroundTruthCommand(CLI::App& app);
void RegisterSimulateCommand(CLI::App& app);
void RegisterRenderCommand(CLI::App& app);
void RegisterCompareCommand(CLI::App& app);
void RegisterViewCommand(CLI::App& app);

}  // namespace mesocap
