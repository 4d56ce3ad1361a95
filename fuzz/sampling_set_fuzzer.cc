// Drives core::ReadSamplingSet with the input as a JSON file holding a
// sampling set's object (docs/FORMATS.md "Sampling sets", JSON form).
#include "core/json_field_reader.h"
#include "core/sampling_set.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  const std::filesystem::path file = fuzz::ScratchDir() / "sampling_set.json";
  fuzz::WriteFileBytes(file, fuzz::Bytes(data, size));
  return fuzz::ReadRejectingOnlyWithError([&] {
    const nlohmann::json document = core::ReadJsonFile(file);
    core::ReadSamplingSet(core::JsonFieldReader(document, file));
  });
}
