// Drives formats::ReadSweepAnalysis on fuzz::TinySweepAnalysis with one of
// its two files replaced by the input: first byte even, the JSON; odd, the
// EXR beside it. The file is restored afterwards.
#include "formats/sweep_analysis.h"
#include "fuzz/fuzz_input.h"
#include "fuzz/tiny_instances.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  static const std::filesystem::path file = [] {
    const std::filesystem::path f = fuzz::ScratchDir() / "sweep.json";
    formats::WriteSweepAnalysis(f, fuzz::TinySweepAnalysis());
    return f;
  }();
  const fuzz::VariantInput input = fuzz::SplitVariant(fuzz::Bytes(data, size), 2);
  const std::filesystem::path target = input.variant == 0 ? file : std::filesystem::path(file.string() + ".exr");
  const std::string original = fuzz::ReadFileBytes(target);
  fuzz::WriteFileBytes(target, input.bytes);
  fuzz::ReadRejectingOnlyWithError([&] { formats::ReadSweepAnalysis(file); });
  fuzz::WriteFileBytes(target, original);
  return 0;
}
