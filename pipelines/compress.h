// The compression job (`mesocap compress`, and how the renderer's built-in
// materials are made from ground truth): the full BTF of a material package
// factored by SVD (MDF paper Sec. 5) into a new package, with the MDF,
// ambient term and calibration copied through and the compression figures
// added to the error report ("btf_compression").
#pragma once

#include <filesystem>

#include "btf/btf_compression.h"
#include "core/error.h"

namespace mesocap::pipelines {

struct CompressOptions {
  std::filesystem::path in;   // material package holding a full BTF
  std::filesystem::path out;  // material package folder to write
  btf::BtfCompressionOptions compression;
  bool replace = false;  // replace an existing package at `out`

  core::CheckResult Check() const;
};

// The full BTF is streamed from the view files, never whole in memory.
// Throws Error ("compress: ...") for bad options, when `in` has no full BTF,
// when `out` exists and `replace` is false, or on any read or write failure;
// nothing is left at `out` then.
btf::BtfCompressionReport RunCompress(const CompressOptions& options);

}  // namespace mesocap::pipelines
