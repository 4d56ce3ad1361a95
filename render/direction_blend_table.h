// SamplingSet::Interpolate tabulated over the hemisphere, so that the
// fragment shader blends neighbouring view and light directions with exactly the CPU's weights instead of a second
// implementation of the ring search. The table is indexed by (phi, theta) cell;
// a lookup takes the blend of the cell's centre, so directions are quantized
// to the cell size (2.8 x 1.4 degrees at the default size).
#pragma once

#include <array>
#include <vector>

#include "core/sampling_set.h"

namespace mesocap::render {

struct DirectionBlendTable {
  int phi_cells = 0;                         // over [0, 2 pi)
  int theta_cells = 0;                       // over [0, pi/2]; directions below the horizon use the last row
  std::vector<std::array<int, 4>> index;     // phi_cells * theta_cells, row-major by theta
  std::vector<std::array<float, 4>> weight;  // unused entries have weight 0 and index 0
};

DirectionBlendTable MakeDirectionBlendTable(const core::SamplingSet& set, int phi_cells = 128, int theta_cells = 64);

}  // namespace mesocap::render
