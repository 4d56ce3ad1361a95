// A material package with its BTF factored (Wang et al. 2005 Sec. 5): what
// `mesocap compress` writes, and how the renderer's built-in materials are
// made from ground truth.
#pragma once

#include <filesystem>

#include "btf/btf_compression.h"

namespace mesocap::btf {

// Writes a new package at `out` holding the full BTF of the package at `in`
// factored by CompressBtf, with its MDF, ambient term and calibration copied
// through and the compression figures added to its error report
// ("btf_compression"). Throws Error when `in` has no full BTF, when `out`
// exists and `replace` is false, or on any read or write failure; nothing is
// left at `out` then.
BtfCompressionReport CompressMaterialPackage(const std::filesystem::path& in, const std::filesystem::path& out,
                                             const BtfCompressionOptions& options, bool replace);

}  // namespace mesocap::btf
