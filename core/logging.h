// Logging through spdlog to stderr, so stdout stays for results (tables, JSON).
#pragma once

#include <cstdio>

namespace mesocap::core {

// verbosity: -1 = warnings and errors only (-q), 0 = info, 1 = debug (-v),
// 2 and above = trace (-vv). Below 1, what libraries print on stderr
// themselves (libpng's "libpng error: ...", libtiff's warnings) is dropped:
// the process's stderr then goes to /dev/null and mesocap's own messages
// (log, progress, the CLI's error line) to a copy of it, MessageStream().
void ConfigureLogging(int verbosity);

// Where mesocap's own messages go: stderr, or its copy once
// ConfigureLogging has set library output aside.
std::FILE* MessageStream();

// Whether informational output (progress included) is wanted: not under -q.
bool InfoWanted();

}  // namespace mesocap::core
