// mesocap: one CLI for capture processing, evaluation and rendering; each
// subcommand is registered from its own file (see command.h).
#include <malloc.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "apps/mesocap/command.h"
#include "core/error.h"
#include "core/logging.h"
#include "core/version.h"

int main(int argc, char** argv) {
  // Frames (a 1024 x 768 RGB float frame is 9.4 MB) are made and freed by
  // the thousand in a capture: glibc would map each one afresh and fault in
  // its pages (a fifth of a paper-rig sweep's time, all of it system time).
  // Keep such blocks in the heap for reuse instead. (Best effort: a
  // sanitizer's allocator ignores this.)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  CLI::App app{"mesocap: capture, process and render measured mesostructure (BTF + MDF)"};
  app.set_version_flag("--version", std::string("mesocap ") + mesocap::core::Version());
  app.require_subcommand(1);
  app.fallthrough();

  int verbose = 0;
  int quiet = 0;
  app.add_flag("-v,--verbose", verbose, "more log output (-vv for trace)");
  app.add_flag("-q,--quiet", quiet, "only warnings and errors in the log");

  // Runs after the flags are parsed and before any subcommand's callback.
  app.parse_complete_callback([&] { mesocap::core::ConfigureLogging(verbose - quiet); });

  mesocap::RegisterInfoCommand(app);
  mesocap::RegisterGroundTruthCommand(app);
  mesocap::RegisterSimulateCommand(app);
  mesocap::RegisterCompressCommand(app);
  mesocap::RegisterEvalBtfCommand(app);
  mesocap::RegisterProcessBtfCommand(app);
  mesocap::RegisterProcessMdfCommand(app);
  mesocap::RegisterEvalMdfCommand(app);
  mesocap::RegisterExportBonnCommand(app);
  mesocap::RegisterImportBonnCommand(app);
  mesocap::RegisterRenderCommand(app);
  mesocap::RegisterCompareCommand(app);
  mesocap::RegisterViewCommand(app);
  mesocap::RegisterVerifyCommand(app);

  // Subcommands report failure by throwing; every failure is one line on
  // stderr and a non-zero exit (1 for errors, CLI11's codes for usage).
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const mesocap::core::Error& e) {
    std::fprintf(stderr, "mesocap: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mesocap: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
