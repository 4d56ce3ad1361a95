#include "core/file_checksum.h"

#include <xxhash.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <memory>
#include <vector>

#include "core/error.h"

namespace mesocap::core {
namespace fs = std::filesystem;

FileChecksum ComputeFileChecksum(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string() + ": cannot open to check its contents: " + std::strerror(errno));
  const std::unique_ptr<XXH3_state_t, decltype(&XXH3_freeState)> state(XXH3_createState(), &XXH3_freeState);
  if (!state || XXH3_64bits_reset(state.get()) != XXH_OK) throw Error("cannot set up the XXH3 hash");
  std::vector<char> chunk(1 << 20);
  FileChecksum sum;
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    const auto n = static_cast<std::size_t>(in.gcount());
    XXH3_64bits_update(state.get(), chunk.data(), n);
    sum.bytes += n;
  }
  if (in.bad()) throw Error(file.string() + ": read failed while checking its contents");
  sum.xxh3 = XXH3_64bits_digest(state.get());
  return sum;
}

FileChecksum ComputeChecksum(std::string_view bytes) { return {bytes.size(), XXH3_64bits(bytes.data(), bytes.size())}; }

std::string ChecksumText(std::uint64_t xxh3) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text(16, '0');
  for (int i = 15; i >= 0; --i, xxh3 >>= 4) text[i] = kDigits[xxh3 & 0xf];
  return text;
}

std::optional<std::uint64_t> ParseChecksumText(std::string_view text) {
  if (text.size() != 16) return std::nullopt;
  std::uint64_t value = 0;
  for (const char c : text) {
    int digit;
    if (c >= '0' && c <= '9') {
      digit = c - '0';
    } else if (c >= 'a' && c <= 'f') {
      digit = c - 'a' + 10;
    } else {
      return std::nullopt;
    }
    value = value << 4 | static_cast<std::uint64_t>(digit);
  }
  return value;
}

std::string ChecksumProblem(const fs::path& file, const FileChecksum& expected) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return "missing or not a regular file";
  const std::uintmax_t size = fs::file_size(file, ec);
  if (ec) return "cannot read its size: " + ec.message();
  if (size != expected.bytes) {
    return "is " + std::to_string(size) + " bytes, expected " + std::to_string(expected.bytes) +
           " (truncated or changed after it was written)";
  }
  const FileChecksum actual = ComputeFileChecksum(file);
  if (actual.bytes != expected.bytes) {
    return "changed while being checked (" + std::to_string(actual.bytes) + " bytes read)";
  }
  if (actual.xxh3 != expected.xxh3) {
    return "content changed after it was written (xxh3 " + ChecksumText(actual.xxh3) + ", expected " +
           ChecksumText(expected.xxh3) + ")";
  }
  return {};
}

void ExpectFileChecksum(const fs::path& file, const FileChecksum& expected) {
  if (const std::string problem = ChecksumProblem(file, expected); !problem.empty()) {
    throw FormatError(file, "checksum", problem);
  }
}

}  // namespace mesocap::core
