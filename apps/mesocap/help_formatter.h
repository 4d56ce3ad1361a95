// The layout of every `--help` of the mesocap CLI: the usage line first,
// then the description, then the options. The text is wrapped at a fixed
// width, never the terminal's, so docs/CLI.md (generated from it by
// scripts/generate_cli_doc.py) is the same on every machine.
#pragma once

#include <CLI/CLI.hpp>
#include <cstddef>
#include <string>

namespace mesocap {

// `text` wrapped at `width` columns between words; a line break in it stays
// one, and a line's leading spaces indent its continuation lines.
std::string WrapText(const std::string& text, std::size_t width);

// A command's description is a one-line summary, shown in its parent's list
// of subcommands, then, after a blank line, what its own --help adds.
class HelpFormatter : public CLI::Formatter {
 public:
  static constexpr std::size_t kWidth = 80;

  std::string make_help(const CLI::App* app, std::string name, CLI::AppFormatMode mode) const override;
  std::string make_description(const CLI::App* app) const override;
  std::string make_subcommand(const CLI::App* sub) const override;
  std::string make_option_desc(const CLI::Option* opt) const override;
  std::string make_footer(const CLI::App* app) const override;
};

}  // namespace mesocap
