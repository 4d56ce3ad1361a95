// Drives bonn::ReadBonnBtfFile with the input as an FMF or DFMF file, then,
// as the Bonn import does, its direction sets and factors as mesocap's.
#include "fuzz/fuzz_input.h"
#include "interop/bonn/bonn_btf_file.h"
#include "interop/bonn/bonn_interop.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  const std::filesystem::path file = fuzz::ScratchDir() / "material.btf";
  fuzz::WriteFileBytes(file, fuzz::Bytes(data, size));
  return fuzz::ReadRejectingOnlyWithError([&] {
    const bonn::BonnBtfFile btf = bonn::ReadBonnBtfFile(file);
    bonn::FactoredFromBonn(btf, file);
  });
}
