// mesocap: one CLI for capture processing, evaluation and rendering; each
// subcommand is registered from its own file (see command.h).
#include <malloc.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <memory>
#include <new>
#include <nlohmann/json.hpp>
#include <string>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_formatter.h"
#include "apps/mesocap/help_text.h"
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
  // Named here, not after argv[0], so that the help is the same whatever path runs it.
  CLI::App app{mesocap::HelpText("mesocap"), "mesocap"};
  app.formatter(std::make_shared<mesocap::HelpFormatter>());  // before the subcommands, which share it
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
  mesocap::RegisterRigCheckCommand(app);
  mesocap::RegisterServeCamerasCommand(app);
  mesocap::RegisterCalibrateCommand(app);
  mesocap::RegisterCaptureCommand(app);

  // Subcommands report failure by throwing; every failure is one line on
  // stderr and a non-zero exit (1 for errors, CLI11's codes for usage).
  // Messages echo cut values already; the cut here keeps even an unforeseen
  // one to a line.
  const auto print = [](const char* kind, const char* what) {
    std::fprintf(mesocap::core::MessageStream(), "mesocap: %s: %s\n", kind,
                 mesocap::core::Cut(what, 4 * mesocap::core::kMaxEchoedCharacters).c_str());
  };
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    print("error", e.what());
    return 2;  // a usage error, as shells and getopt tools report one
  } catch (const mesocap::core::Error& e) {
    print("error", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    print("error", "out of memory (an allocation failed where its size was not checked)");
    return 1;
  } catch (const nlohmann::json::exception& e) {
    // Without nlohmann's "[json.exception.type_error.302] " id.
    const std::string what = e.what();
    print("internal error", what.substr(what.find("] ") == std::string::npos ? 0 : what.find("] ") + 2).c_str());
    return 1;
  } catch (const std::exception& e) {
    print("internal error", e.what());
    return 1;
  }
  return 0;
}
