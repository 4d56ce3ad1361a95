#include "core/error.h"

#include <unistd.h>

#include <sstream>

namespace mesocap::core {
namespace {

std::uint64_t PhysicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page_size = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page_size <= 0) return UINT64_MAX;
  return static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page_size);
}

// A path longer than an echoed value keeps its end, where the file's name is.
std::string CutPath(const std::string& path) {
  if (path.size() <= kMaxEchoedCharacters) return path;
  std::size_t start = path.size() - kMaxEchoedCharacters;
  while (start < path.size() && (static_cast<unsigned char>(path[start]) & 0xC0) == 0x80) ++start;
  return "(" + std::to_string(path.size()) + " bytes in all) ..." + Cut(path.substr(start));
}

}  // namespace

FormatError::FormatError(std::filesystem::path file, std::string field, const std::string& problem)
    : Error(CutPath(file.string()) + ": " + (field.empty() ? std::string() : "field '" + Cut(field) + "': ") + problem),
      file_(std::move(file)),
      field_(std::move(field)) {}

std::string Cut(std::string_view text, std::size_t max) {
  std::size_t end = text.size();
  if (end > max) {
    end = max;
    // Never split a UTF-8 sequence: back up over its continuation bytes.
    while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80) --end;
  }
  std::string out(text.substr(0, end));
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  }
  if (end < text.size()) out += "... (" + std::to_string(text.size()) + " bytes in all)";
  return out;
}

std::string Quoted(std::string_view value) { return "\"" + Cut(value) + "\""; }

std::string Fixed(double value, int digits) {
  std::ostringstream text;
  text.setf(std::ios::fixed);
  text.precision(digits);
  text << value;
  return text.str();
}

void CheckMemoryFor(std::uint64_t bytes, std::string_view what) {
  if (bytes > PhysicalMemoryBytes()) ThrowOutOfMemory(bytes, what);
}

void ThrowOutOfMemory(std::uint64_t bytes, std::string_view what) {
  throw Error("needs " + std::to_string(bytes) + " bytes for " + std::string(what) + "; limit " +
              std::to_string(PhysicalMemoryBytes()) + " bytes (this machine's memory)");
}

}  // namespace mesocap::core
