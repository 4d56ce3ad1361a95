// The Bonn BTF database's sampling sets (UBO2003, UBO2014 dome 1) and the
// lookup of a sampling set by name that knows them as well as core's own
// named sets (paper12x5, paper12x8, grid<A>x<P>): what a user's set name
// (`--views ubo2003`) goes through.
#pragma once

#include <string>

#include "core/sampling_set.h"

namespace mesocap::bonn {

// Every named set (docs/FORMATS.md "Sampling sets" gives every angle):
//   "ubo2003": Bonn UBO2003, 81 directions;  "ubo2014": Bonn UBO2014 (dome 1), 151
//   and core's: "paper12x5", "paper12x8", "grid<A>x<P>" (core::SamplingSet::Named)
// Throws Error listing the valid names for anything else.
core::SamplingSet NamedSamplingSet(const std::string& name);

}  // namespace mesocap::bonn
