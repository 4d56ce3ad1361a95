// A material as the renderers use it (Wang et al. 2005 Sec. 4-5): the
// SVD-factored BTF, the MDF, the ambient term La and, when the material
// comes from a simulated scene, the true tile geometry for the CPU
// reference renderer.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "core/btf.h"
#include "core/mdf.h"
#include "formats/material_package.h"
#include "sim/tile_geometry.h"

namespace mesocap::render {

struct RenderMaterial {
  std::string name;
  std::filesystem::path package;  // the material package it was read from
  double sample_size_mm = 0.0;    // side of the square one texture unit covers
  double d_max_mm = 0.0;
  core::FactoredBtf btf;
  core::Mdf mdf;
  formats::AmbientTerm ambient;
  // The geometry the material was made from (simulated materials only): the
  // reference renderer maps it onto meshes. Absent for measured materials.
  std::optional<sim::TileGeometry> geometry;
};

// Reads a package that has a factored BTF, an MDF and an ambient term.
// Throws FormatError naming the package's manifest and the missing part
// ("run `mesocap compress` first" for a package with only a full BTF).
RenderMaterial LoadRenderMaterial(const std::filesystem::path& package);

}  // namespace mesocap::render
