// Drives sim::ReadFaultPlan with the input as a mesocap.faults file.
#include "fuzz/fuzz_input.h"
#include "sim/fault_plan.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  const std::filesystem::path file = fuzz::ScratchDir() / "faults.json";
  fuzz::WriteFileBytes(file, fuzz::Bytes(data, size));
  return fuzz::ReadRejectingOnlyWithError([&] { sim::ReadFaultPlan(file); });
}
