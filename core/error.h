// Errors a user can cause: a bad file, a bad option, a device that fails.
// Every message is one readable line; the CLI prints it and exits non-zero.
#pragma once

#include <filesystem>
#include <stdexcept>
#include <string>

namespace mesocap::core {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// A file that exists but does not hold what its format requires. The message
// names the file, the field (a JSON path such as "cameras[1].intrinsics.fx",
// or an image property such as "width") and what was expected.
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

}  // namespace mesocap::core
