// What every fuzzer shares: a scratch folder of its own process, where the
// fuzz input becomes a file (or one file of a valid folder) that a reader
// then reads. A reader may reject an input only with core::Error (FormatError
// included); any other exception escapes LLVMFuzzerTestOneInput and
// libFuzzer reports it as a crash, like a sanitizer's report.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string_view>

#include "core/error.h"

namespace mesocap::fuzz {

// The fuzz input as bytes.
inline std::string_view Bytes(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// A folder under the system temp dir, /tmp/mesocap-fuzz-<pid>, made on first
// use and removed when the process exits normally.
const std::filesystem::path& ScratchDir();

// Writes `bytes` to `file` (truncating it), bypassing the atomic writers:
// the reader must cope with whatever is there.
void WriteFileBytes(const std::filesystem::path& file, std::string_view bytes);
std::string ReadFileBytes(const std::filesystem::path& file);

// Runs `read`; an input it rejects with core::Error is fine.
template <typename Read>
int ReadRejectingOnlyWithError(Read&& read) {
  try {
    read();
  } catch (const core::Error&) {
  }
  return 0;
}

// The first byte of an input picks one of `count` variants (an image
// container, a file of a folder); the rest is the file's content.
struct VariantInput {
  std::size_t variant = 0;
  std::string_view bytes;
};
VariantInput SplitVariant(std::string_view input, std::size_t count);

}  // namespace mesocap::fuzz
