// `mesocap info PATH`: a readable summary of an image (more kinds of file are
// added as their formats land), or one JSON object with --json.
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "apps/mesocap/command.h"
#include "core/error.h"
#include "core/image_io.h"

namespace mesocap {
namespace {

struct InfoOptions {
  std::filesystem::path path;
  bool json = false;
};

void RunInfo(const InfoOptions& options) {
  const ImageHeader h = ReadImageHeader(options.path);
  nlohmann::json out = {{"kind", "image"},
                        {"path", options.path.string()},
                        {"width", h.width},
                        {"height", h.height},
                        {"channels", h.channels},
                        {"encoding", ToString(h.encoding)}};
  if (options.json) {
    std::cout << out.dump(2) << "\n";
  } else {
    std::cout << "image " << options.path.string() << ": " << h.width << "x" << h.height << ", "
              << h.channels << " channel(s), " << ToString(h.encoding) << "\n";
  }
}

}  // namespace

void RegisterInfoCommand(CLI::App& app) {
  auto options = std::make_shared<InfoOptions>();
  CLI::App* sub = app.add_subcommand(
      "info", "Print a summary of a calibration, capture session, material package or image");
  sub->add_option("path", options->path, "file or folder to describe")->required();
  sub->add_flag("--json", options->json, "print one JSON object instead of text");
  sub->callback([options] { RunInfo(*options); });
}

}  // namespace mesocap
