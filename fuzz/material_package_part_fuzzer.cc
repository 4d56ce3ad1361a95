// Drives formats::ReadMaterialPackage on fuzz::TinyMaterialPackage with one
// of its data files replaced by the input: the first byte picks the file
// (fuzz::FilesOf's order, the manifest left out), the rest is its content.
// The file is restored afterwards, so every input meets the same package.
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "fuzz/fuzz_input.h"
#include "fuzz/tiny_instances.h"

namespace {
struct Package {
  std::filesystem::path dir;
  std::vector<std::filesystem::path> parts;
};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  static const Package package = [] {
    Package p;
    p.dir = fuzz::ScratchDir() / "package";
    formats::WriteMaterialPackage(p.dir, fuzz::TinyMaterialPackage(), false);
    for (const std::filesystem::path& file : fuzz::FilesOf(p.dir)) {
      if (file != "manifest.json") p.parts.push_back(file);
    }
    return p;
  }();
  const fuzz::VariantInput input = fuzz::SplitVariant(fuzz::Bytes(data, size), package.parts.size());
  const std::filesystem::path part = package.dir / package.parts[input.variant];
  const std::string original = fuzz::ReadFileBytes(part);
  fuzz::WriteFileBytes(part, input.bytes);
  fuzz::ReadRejectingOnlyWithError([&] { formats::ReadMaterialPackage(package.dir); });
  fuzz::WriteFileBytes(part, original);
  return 0;
}
