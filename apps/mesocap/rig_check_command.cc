// `mesocap rig check RIG` and `mesocap devices`: the preflight before a
// capture (every device of a rig opened and read, one line each, non-zero
// exit when one fails) and what the real backends find on this machine.
#include <spdlog/spdlog.h>

#include <cstdio>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "pipelines/rig_check.h"

namespace mesocap {

void RegisterRigCheckCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::RigCheckOptions>();
  CLI::App* group = GroupCommand(app, "rig", "Check a rig's devices");
  CLI::App* sub = group->add_subcommand("check", HelpText("rig_check"));
  sub->add_option("rig", o->rig, "rig description file")->required()->check(CLI::ExistingFile);
  sub->callback([o] {
    const auto checks = pipelines::RunRigCheck(*o);
    int failed = 0;
    for (const auto& c : checks) {
      std::printf("%-12s %-28s %s: %s\n", c.device.c_str(), c.backend.c_str(), c.ok ? "ok" : "FAILED", c.state.c_str());
      failed += c.ok ? 0 : 1;
    }
    std::fflush(stdout);
    if (failed > 0) {
      throw core::Error(o->rig.string() + ": " + std::to_string(failed) + " of " + std::to_string(checks.size()) +
                        " devices failed");
    }
  });

  CLI::App* devices = app.add_subcommand("devices", HelpText("devices"));
  devices->callback([] {
    const auto found = pipelines::FindDevices();
    for (const auto& d : found) {
      std::printf("%-10s %-32s %-28s %-12s %s\n", d.kind.c_str(), d.id.c_str(), d.model.c_str(), d.serial.c_str(),
                  d.address.c_str());
    }
    std::fflush(stdout);
    spdlog::info("{} devices found", found.size());
  });
}

}  // namespace mesocap
