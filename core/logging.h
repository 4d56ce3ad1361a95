// Logging through spdlog to stderr, so stdout stays for results (tables, JSON).
#pragma once

namespace mesocap::core {

// verbosity: -1 = warnings and errors only (-q), 0 = info, 1 = debug (-v),
// 2 and above = trace (-vv).
void ConfigureLogging(int verbosity);

}  // namespace mesocap::core
