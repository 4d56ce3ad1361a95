// Drives bonn::ScanUbo2003Folder and ReadUbo2003View on a folder whose file
// names are the input's lines (at most 256), each file the same small PNG:
// what the UBO2003 reader parses and checks is the names.
#include <string>

#include "core/image_io.h"
#include "fuzz/fuzz_input.h"
#include "fuzz/tiny_instances.h"
#include "interop/bonn/bonn_ubo2003.h"

namespace {
// "name" or "subfolder/name": what the reader looks at (the folder and its
// direct subfolders); never a path outside the folder.
bool IsFolderEntry(const std::string& name) {
  if (name.size() > 200 || name.find('\0') != std::string::npos) return false;
  const std::size_t slash = name.find('/');
  const std::string parts[] = {name.substr(0, slash), slash == std::string::npos ? "x" : name.substr(slash + 1)};
  for (const std::string& part : parts) {
    if (part.empty() || part == "." || part == ".." || part.find('/') != std::string::npos) return false;
  }
  return true;
}

// A file, unless a folder of that name is already there (a name used both ways).
void WriteEntry(const std::filesystem::path& path, const std::string& bytes) {
  std::error_code ignored;
  std::filesystem::create_directories(path.parent_path(), ignored);
  if (!ignored && !std::filesystem::exists(path)) mesocap::fuzz::WriteFileBytes(path, bytes);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  namespace fs = std::filesystem;
  static const std::string png = [] {
    const fs::path file = fuzz::ScratchDir() / "image.png";
    core::WriteImage(file, fuzz::TinyImage(3, 2, 3), core::PixelEncoding::kUInt8);
    return fuzz::ReadFileBytes(file);
  }();
  const fs::path dir = fuzz::ScratchDir() / "ubo2003";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::string_view names = fuzz::Bytes(data, size);
  for (int count = 0; !names.empty() && count < 256; ++count) {
    const std::size_t end = std::min(names.find('\n'), names.size());
    const std::string name(names.substr(0, end));
    names.remove_prefix(std::min(end + 1, names.size()));
    if (IsFolderEntry(name)) WriteEntry(dir / name, png);
  }
  return fuzz::ReadRejectingOnlyWithError([&] {
    const bonn::Ubo2003ImageSet set = bonn::ScanUbo2003Folder(dir);
    bonn::ReadUbo2003View(set, 0, 1.0);
  });
}
