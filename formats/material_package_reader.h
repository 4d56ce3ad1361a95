// Reading a material package (material_package.h) part by part, after its
// manifest (ReadMaterialManifest), or whole into memory.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/btf.h"
#include "core/image.h"
#include "core/mdf.h"
#include "formats/calibration.h"
#include "formats/material_manifest.h"
#include "formats/material_package.h"

namespace mesocap::formats {

// Part readers. Each throws FormatError when the manifest has no such part,
// a file's size, channel count or pixel type differs from what the manifest
// implies (checked before allocating), or a value is not a valid encoding.
//
// The float form if present, else the 8-bit form decoded (within scale/2).
core::Mdf ReadMdf(const std::filesystem::path& dir, const MaterialManifest& manifest);
// The per-texel confidence (see MaterialPackageWriter::WriteMdfConfidence);
// FormatError for a value outside [0, 1].
core::Image ReadMdfConfidence(const std::filesystem::path& dir, const MaterialManifest& manifest);
// The 8-bit form as stored (what a renderer uploads as a 3D texture).
core::QuantizedMdf ReadQuantizedMdf(const std::filesystem::path& dir, const MaterialManifest& manifest);
// One view of the full BTF (see MaterialPackageWriter::WriteFullBtfView for
// the layout). To pass over a BTF too large for memory, use
// PackageFullBtfReader (package_full_btf_reader.h).
core::Image ReadFullBtfView(const std::filesystem::path& dir, const MaterialManifest& manifest, int view);
core::FullBtf ReadFullBtf(const std::filesystem::path& dir, const MaterialManifest& manifest);
core::FactoredBtf ReadFactoredBtf(const std::filesystem::path& dir, const MaterialManifest& manifest);
AmbientTerm ReadAmbientTerm(const std::filesystem::path& dir, const MaterialManifest& manifest);
nlohmann::json ReadErrorReport(const std::filesystem::path& dir, const MaterialManifest& manifest);
Calibration ReadPackageCalibration(const std::filesystem::path& dir, const MaterialManifest& manifest);
// Everything, in memory.
MaterialPackage ReadMaterialPackage(const std::filesystem::path& dir);

}  // namespace mesocap::formats
