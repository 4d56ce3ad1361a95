// The triangles of the built-in scenes (MakeBuiltinScene builds the traced
// scene from them); for tests that check the tracer against brute force.
#pragma once

#include <string>

#include "sim/tile_geometry.h"

namespace mesocap::sim {

// Throws mesocap::Error for a name not in BuiltinSceneNames().
TileGeometry BuiltinTileGeometry(const std::string& name);

}  // namespace mesocap::sim
