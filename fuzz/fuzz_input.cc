#include "fuzz/fuzz_input.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

namespace mesocap::fuzz {
namespace fs = std::filesystem;

namespace {
void RemoveScratchDir() {
  std::error_code ignored;
  fs::remove_all(ScratchDir(), ignored);
}
}  // namespace

const fs::path& ScratchDir() {
  static const fs::path dir = [] {
    const fs::path path = fs::temp_directory_path() / ("mesocap-fuzz-" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
    return path;
  }();
  // Registered once `dir` is made, so that it runs before `dir` is destroyed.
  [[maybe_unused]] static const int removed_at_exit = std::atexit(RemoveScratchDir);
  return dir;
}

void WriteFileBytes(const fs::path& file, std::string_view bytes) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out.flush()) throw std::runtime_error("cannot write fuzz input " + file.string());
}

std::string ReadFileBytes(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  return {std::istreambuf_iterator<char>(in), {}};
}

VariantInput SplitVariant(std::string_view input, std::size_t count) {
  if (input.empty()) return {0, input};
  return {static_cast<unsigned char>(input[0]) % count, input.substr(1)};
}

}  // namespace mesocap::fuzz
