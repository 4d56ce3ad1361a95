// Drives formats::ReadRigDescription (and so ParseRigDescription) with the
// input as a rig description file.
#include "formats/rig_description.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  const std::filesystem::path file = fuzz::ScratchDir() / "rig.json";
  fuzz::WriteFileBytes(file, fuzz::Bytes(data, size));
  return fuzz::ReadRejectingOnlyWithError([&] { formats::ReadRigDescription(file); });
}
