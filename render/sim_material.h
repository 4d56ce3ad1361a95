// How the built-in simulated materials of the scenes ("sim:brick") are made
// from ground truth: the sample square holds a whole
// number of tiles (at least 12 mm), so the texture repeats without seams on a
// mesh, and the directions reach close to grazing, where silhouettes are
// decided.
#pragma once

#include <string>

#include "sim/ground_truth.h"

namespace mesocap::render {

// Throws Error for a name that is not a built-in scene.
sim::GroundTruthOptions SimMaterialGroundTruthOptions(const std::string& scene_name);

}  // namespace mesocap::render
