// The ground-truth job (`mesocap groundtruth`): the exact material package of
// a simulated scene on a rig (MDF, full BTF, ambient term and the rig's true
// calibration), computed directly in texture space (sim/ground_truth.h).
#pragma once

#include <filesystem>
#include <string>

#include "core/error.h"
#include "sim/mesostructure_scene.h"

namespace mesocap::pipelines {

struct GroundTruthOptions {
  sim::SceneSource scene;
  std::string rig = "tiny";   // a shipped rig (sim/shipped_rigs.h) or a rig description file
  std::filesystem::path out;  // the material package folder to write
  int texture_size = 64;      // texels per side
  // The BTF and ambient term are texel-area means over n x n samples
  // (sim::GroundTruthOptions::samples_per_side), as the cameras measure
  // them: at 8 the figures of a measured BTF against it have converged to
  // within 0.1 dB; at 1 (texel centres) they are 3 dB low (docs/BENCHMARKS.md).
  int texel_samples_per_side = 8;
  // View and light directions: "rig" (the rig's own) or a sampling set name
  // (bonn::NamedSamplingSet: paper12x8, ubo2003, grid<A>x<P>, ...).
  std::string views = "rig";
  std::string lights = "rig";
  bool replace = false;  // replace an existing package at `out`

  core::CheckResult Check() const;
};

struct GroundTruthReport {
  std::string scene;
  std::string rig;
};

// Loads the scene and the rig, writes the package at `out` (atomically: on
// failure nothing is left there). Throws Error ("groundtruth: ...") for bad
// options, an unknown set name, or `out` existing without `replace`.
GroundTruthReport RunGroundTruth(const GroundTruthOptions& options);

}  // namespace mesocap::pipelines
