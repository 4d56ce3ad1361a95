// The rig descriptions shipped in sim/rigs/ (tiny, small, paper), compiled
// into the library so `mesocap --rig tiny` works from any folder.
#pragma once

#include <string>
#include <vector>

#include "formats/rig_description.h"

namespace mesocap::sim {

std::vector<std::string> ShippedRigNames();

// A shipped rig by name, or else a rig description file by path. Throws Error
// listing the shipped names when neither exists.
formats::RigDescription LoadRig(const std::string& name_or_path);

}  // namespace mesocap::sim
