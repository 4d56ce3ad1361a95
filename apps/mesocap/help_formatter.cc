#include "apps/mesocap/help_formatter.h"

#include <sstream>

namespace mesocap {
namespace {

std::string WrapLine(const std::string& line, std::size_t width) {
  const std::size_t indent = line.find_first_not_of(' ');
  if (indent == std::string::npos) return {};
  std::istringstream words(line.substr(indent));
  std::string out(indent, ' ');
  std::size_t column = indent;
  std::string word;
  bool first = true;
  while (words >> word) {
    if (!first && column + 1 + word.size() > width) {
      out += "\n" + std::string(indent, ' ');
      column = indent;
      first = true;
    }
    if (!first) {
      out += ' ';
      ++column;
    }
    out += word;
    column += word.size();
    first = false;
  }
  return out;
}

std::string FirstLine(const std::string& text) { return text.substr(0, text.find('\n')); }

}  // namespace

std::string WrapText(const std::string& text, std::size_t width) {
  std::istringstream lines(text);
  std::string out;
  std::string line;
  bool first = true;
  while (std::getline(lines, line)) {
    out += (first ? "" : "\n") + WrapLine(line, width);
    first = false;
  }
  return out;
}

std::string HelpFormatter::make_help(const CLI::App* app, std::string name, CLI::AppFormatMode mode) const {
  if (mode == CLI::AppFormatMode::Sub) return make_expanded(app);
  std::ostringstream out;
  out << make_usage(app, name) << '\n' << make_description(app);
  out << make_positionals(app) << make_groups(app, mode) << make_subcommands(app, mode);
  const std::string footer = make_footer(app);
  if (!footer.empty()) out << '\n' << footer;
  return out.str();
}

std::string HelpFormatter::make_description(const CLI::App* app) const {
  const std::string description = app->get_description();
  return description.empty() ? std::string() : WrapText(description, kWidth) + "\n";
}

std::string HelpFormatter::make_subcommand(const CLI::App* sub) const {
  std::ostringstream out;
  CLI::detail::format_help(out, sub->get_display_name(true),
                           WrapText(FirstLine(sub->get_description()), kWidth - column_width_), column_width_);
  return out.str();
}

std::string HelpFormatter::make_option_desc(const CLI::Option* opt) const {
  return WrapText(opt->get_description(), kWidth - column_width_);
}

std::string HelpFormatter::make_footer(const CLI::App* app) const {
  const std::string footer = app->get_footer();
  return footer.empty() ? std::string() : WrapText(footer, kWidth) + "\n";
}

}  // namespace mesocap
