// Drives formats::ReadMaterialPackage with the input as the manifest.json of
// fuzz::TinyMaterialPackage (every part's files present), so a manifest that
// passes ReadMaterialManifest goes on to the part readers.
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "fuzz/fuzz_input.h"
#include "fuzz/tiny_instances.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  static const std::filesystem::path package = [] {
    const std::filesystem::path dir = fuzz::ScratchDir() / "package";
    formats::WriteMaterialPackage(dir, fuzz::TinyMaterialPackage(), false);
    return dir;
  }();
  fuzz::WriteFileBytes(package / "manifest.json", fuzz::Bytes(data, size));
  return fuzz::ReadRejectingOnlyWithError([&] { formats::ReadMaterialPackage(package); });
}
