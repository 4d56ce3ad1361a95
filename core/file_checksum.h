// Content checksums of the files a capture session or material package
// holds: the size and the 64-bit XXH3 hash of the bytes. Fast enough (tens
// of GB/s from memory) to check every file on every read, and any change of
// a byte changes it. Not a defence against deliberate tampering.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace mesocap::core {

struct FileChecksum {
  std::uint64_t bytes = 0;
  std::uint64_t xxh3 = 0;

  bool operator==(const FileChecksum&) const = default;
};

// Reads the whole file; throws Error naming the file when it cannot.
FileChecksum ComputeFileChecksum(const std::filesystem::path& file);
FileChecksum ComputeChecksum(std::string_view bytes);

// The hash as files write it: 16 lowercase hexadecimal digits.
std::string ChecksumText(std::uint64_t xxh3);
// Parses ChecksumText's form; nullopt for anything else.
std::optional<std::uint64_t> ParseChecksumText(std::string_view text);

// Empty when `file` has the size and hash `expected`, else why not ("is 12
// bytes, expected 3400", "content changed: xxh3 ..., expected ..."). Checks
// the size before hashing.
std::string ChecksumProblem(const std::filesystem::path& file, const FileChecksum& expected);

// Throws FormatError(file, "checksum", ...) when ChecksumProblem is not empty:
// the file was changed or damaged after it was written.
void ExpectFileChecksum(const std::filesystem::path& file, const FileChecksum& expected);

}  // namespace mesocap::core
