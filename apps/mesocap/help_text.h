// The long descriptions of the subcommands (what `--help` prints above the
// options, and docs/CLI.md with it) are prose, kept one file a subcommand in
// apps/mesocap/help/ and embedded in the binary when it is built: a summary
// line, a blank line, then a paragraph a line.
#pragma once

#include <string>
#include <string_view>

namespace mesocap {

// The text of the file named `key` (its name without .txt, such as
// "process_mdf"). Throws std::logic_error for a key without a file: a
// mistake in the program, which every subcommand's --help shows at once.
std::string HelpText(std::string_view key);

}  // namespace mesocap
