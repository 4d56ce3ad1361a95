// The tiled tracer: one tile of geometry, repeated with period P in x and y,
// traced cell by cell with Embree (see tiled_scene.cc for the method and its
// precision guards).
#pragma once

#include <memory>

#include "sim/mesostructure_scene.h"
#include "sim/tile_geometry.h"

namespace mesocap::sim {

// Checks the geometry (CheckTileGeometry) and builds the Embree scene once.
// Throws mesocap::Error when Embree cannot build it.
std::unique_ptr<MesostructureScene> MakeTiledScene(TileGeometry geometry);

}  // namespace mesocap::sim
