// Drives core::ReadImage (OpenImageIO) with the input as an image file; the
// first byte picks the container by extension: .exr, .png or .tif.
#include "core/image_io.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  static constexpr const char* kExtensions[] = {".exr", ".png", ".tif"};
  const fuzz::VariantInput input = fuzz::SplitVariant(fuzz::Bytes(data, size), std::size(kExtensions));
  const std::filesystem::path file = fuzz::ScratchDir() / (std::string("image") + kExtensions[input.variant]);
  fuzz::WriteFileBytes(file, input.bytes);
  return fuzz::ReadRejectingOnlyWithError([&] { core::ReadImage(file); });
}
