// How CompressBtf words its report and log: errors, sizes and the names of
// representations. Internal to btf/; ToJson (btf/btf_compression.h) writes
// the report itself.
#pragma once

#include <string>

#include "core/btf.h"

namespace mesocap::btf::compression {

// A relative error as a percentage, 3 significant digits ("0.512%").
std::string Percent(double relative);

// "paper/rgb", "clustered(32)/ycbcr": a layout, its cluster count, a colour.
std::string RepresentationName(core::BtfFactorLayout layout, core::BtfFactorColor color, int clusters);

// A size in KiB, MiB or GiB, 3 significant digits.
std::string Bytes(long long bytes);

}  // namespace mesocap::btf::compression
