// Errors a user can cause: a bad file, a bad option, a device that fails.
// Every message is one readable line; the CLI prints it and exits non-zero.
#pragma once

#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <string_view>

namespace mesocap::core {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A file that exists but does not hold what its format requires. The message
// names the file, the field (a JSON path such as "cameras[1].intrinsics.fx",
// or an image property such as "width") and what was expected. The field is
// cut as Cut() does (it may be a hostile file's member name), and a path
// longer than that keeps its end.
class FormatError : public Error {
 public:
  FormatError(std::filesystem::path file, std::string field, const std::string& problem);

  const std::filesystem::path& file() const { return file_; }
  const std::string& field() const { return field_; }

 private:
  std::filesystem::path file_;
  std::string field_;
};

// Options structs' Check() return this on failure; empty means valid.
// Kept as a string (not an exception) so callers can collect several.
using CheckResult = std::string;

// The one way to refuse options: throws ErrorType("WHO: PROBLEM") when
// Check() found a problem, WHO naming the command or part that was given
// them ("process mdf", "stepper turntable").
template <typename ErrorType = Error>
void ThrowIfInvalid(const CheckResult& problem, const std::string& who) {
  if (!problem.empty()) throw ErrorType(who + ": " + problem);
}

// A value echoed in a message (a name read from a file, a flag's text) is
// cut to this many characters, so a 3 MB name still gives a readable line.
inline constexpr std::size_t kMaxEchoedCharacters = 200;

// `text` on one line (control characters as '?') and at most `max`
// bytes (never inside a UTF-8 character), followed by "... (N bytes in all)"
// when it was cut.
std::string Cut(std::string_view text, std::size_t max = kMaxEchoedCharacters);
// `value` cut as Cut() does, in double quotes: how messages quote a value.
std::string Quoted(std::string_view value);
// A number for a message, with `digits` digits after the point.
std::string Fixed(double value, int digits);

// An allocation the inputs allow but the process cannot hold: "needs N bytes
// for WHAT; limit L bytes (this machine's memory)", in place of bad_alloc.
// The limit is the tightest of the machine's memory, what ulimit -v leaves
// beside what is mapped already, and ulimit -d; the message names it.
void CheckMemoryFor(std::uint64_t bytes, std::string_view what);
// The message for an allocation of `bytes` that failed anyway.
[[noreturn]] void ThrowOutOfMemory(std::uint64_t bytes, std::string_view what);

}  // namespace mesocap::core
