// Drives formats::FrameSequenceReader with the input as a multi-frame TIFF,
// reading every frame.
#include "formats/frame_sequence.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  const std::filesystem::path file = fuzz::ScratchDir() / "frames.tif";
  fuzz::WriteFileBytes(file, fuzz::Bytes(data, size));
  return fuzz::ReadRejectingOnlyWithError([&] {
    formats::FrameSequenceReader reader(file);
    core::Image frame;
    while (reader.Next(&frame)) {
    }
  });
}
