// The fixed layout of a material package folder (its file names) and the
// checks that its manifest, its writer and its readers share. Internal to the
// material package's files in formats/; everything else uses
// material_manifest.h, material_package_writer.h and material_package_reader.h.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <sstream>
#include <string>

#include "core/image.h"
#include "formats/material_manifest.h"

namespace mesocap::formats {

// File names are fixed by the format; the manifest repeats them so that other
// tools see what a package holds, and a reader accepts only these (a manifest
// can never point outside its folder).
inline constexpr char kManifestFile[] = "manifest.json";
inline constexpr char kMdfFloatFile[] = "mdf.exr";
inline constexpr char kMdfUint8File[] = "mdf8.tif";
inline constexpr char kMdfConfidenceFile[] = "mdf_confidence.exr";
inline constexpr char kFullBtfFiles[] = "btf/view_{view:04d}.exr";
inline constexpr char kRowFactorFiles[] = "btf/rows_{k:02d}.exr";
inline constexpr char kColumnFactorFile[] = "btf/columns.exr";
inline constexpr char kClusterFile[] = "btf/clusters.exr";  // clustered layout: each texel's cluster
inline constexpr char kAmbientFile[] = "ambient.exr";
inline constexpr char kErrorReportFile[] = "error_report.json";
inline constexpr char kCalibrationFile[] = "calibration.json";

// The manifest and the error report are small; a larger file is not one.
inline constexpr std::uintmax_t kMaxJsonBytes = 16u << 20;

inline std::string NumberText(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

// Images pack a direction set along their height (Sec. 5's 3D textures).
inline int PackedHeight(const MaterialDescription& d, const core::SamplingSet& set) { return d.height * set.size(); }

// Index of the first value outside [0, 1] (NaN included), or size() if none.
inline std::size_t FirstOutsideUnitInterval(const core::Image& image) {
  const float* values = image.data();
  for (std::size_t i = 0; i < image.size(); ++i) {
    if (!(values[i] >= 0.0f && values[i] <= 1.0f)) return i;
  }
  return image.size();
}

// Empty when the float data a part implies is plausible (at most
// kMaxPartBytes), else why not.
std::string OversizeProblem(const MaterialDescription& d, const char* part, bool with_lights, int channels);

// Throws the FormatError of a part reader asked for a part the manifest of
// the package in `dir` does not list (`field` is the manifest's key).
[[noreturn]] void ThrowMissingPart(const std::filesystem::path& dir, const char* field, const char* what);

// Writes `dir`/manifest.json; MaterialPackageWriter::Commit is its only user,
// since a manifest must list exactly the files written beside it.
void WriteMaterialManifest(const std::filesystem::path& dir, const MaterialManifest& manifest);

}  // namespace mesocap::formats
