#include "core/error.h"

#include <sys/resource.h>
#include <unistd.h>

#include <fstream>
#include <sstream>

namespace mesocap::core {
namespace {

std::uint64_t PhysicalMemoryBytes() {
  const long pages = ::sysconf(_SC_PHYS_PAGES);
  const long page_size = ::sysconf(_SC_PAGESIZE);
  if (pages <= 0 || page_size <= 0) return UINT64_MAX;
  return static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page_size);
}

// The process's mapped address space now (/proc/self/statm's first field).
std::uint64_t MappedBytes() {
  std::ifstream statm("/proc/self/statm");
  std::uint64_t pages = 0;
  statm >> pages;
  return pages * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE));
}

// What an allocation may take, and the limit that says so: the machine's
// memory, or less where ulimit -v or -d caps the process (what is mapped
// already counts against ulimit -v).
struct MemoryLimit {
  std::uint64_t available = UINT64_MAX;
  std::string text;
};

MemoryLimit CurrentMemoryLimit() {
  MemoryLimit limit{PhysicalMemoryBytes(), ""};
  limit.text = std::to_string(limit.available) + " bytes (this machine's memory)";
  rlimit rl{};
  if (::getrlimit(RLIMIT_AS, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY) {
    const std::uint64_t mapped = MappedBytes();
    const std::uint64_t left = rl.rlim_cur > mapped ? rl.rlim_cur - mapped : 0;
    if (left < limit.available) {
      limit = {left, std::to_string(left) + " bytes left of the process's address-space limit of " +
                         std::to_string(rl.rlim_cur) + " bytes (ulimit -v)"};
    }
  }
  if (::getrlimit(RLIMIT_DATA, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY && rl.rlim_cur < limit.available) {
    limit = {rl.rlim_cur, std::to_string(rl.rlim_cur) + " bytes (the process's data limit, ulimit -d)"};
  }
  return limit;
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
  const MemoryLimit limit = CurrentMemoryLimit();
  if (bytes > limit.available) {
    throw Error("needs " + std::to_string(bytes) + " bytes for " + std::string(what) + "; limit " + limit.text);
  }
}

void ThrowOutOfMemory(std::uint64_t bytes, std::string_view what) {
  throw Error("could not allocate " + std::to_string(bytes) + " bytes for " + std::string(what) + "; limit " +
              CurrentMemoryLimit().text + ", less what is in use");
}

}  // namespace mesocap::core
