// The Bonn import job (`mesocap import bonn`): a Bonn BTF database form (a
// UBO2003 image folder, or a UBO2014 FMF / DFMF file told by its signature)
// read into a material package with the BTF (full and/or factored), its
// ambient term (btf/ambient_term.h) and, on request, a flat MDF, through the
// conversions of interop/bonn/ (how the data map is told in
// interop/bonn/bonn_interop.h).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "core/error.h"
#include "formats/material_manifest.h"
#include "interop/bonn/bonn_interop.h"

namespace mesocap::pipelines {

// Ranges of the lengths an import is told (--d-max-mm, --size-mm), in mm.
inline constexpr double kMinBonnLengthMm = 1e-6;
inline constexpr double kMaxBonnDMaxMm = 1e4;
inline constexpr double kMaxBonnWidthMm = 1e6;

enum class BonnImportParts { kFactored, kFull, kBoth };

struct ImportBonnOptions {
  std::filesystem::path in;   // image folder (tl..._pl..._tv..._pv....png/.exr) or FMF/DFMF file
  std::filesystem::path out;  // material package folder to write
  // The Bonn forms carry no mesostructure depth, but every package states
  // d_max (docs/FORMATS.md): required, > 0.
  double d_max_mm = 0.0;
  // Physical width of the texture (height follows for square texels); 0:
  // from the binary file's pixels per mm. Required for the image form.
  double width_mm = 0.0;
  // Default: factored for FMF/DFMF (exact, what the renderer reads), full
  // for the image form (the only one it can be).
  std::optional<BonnImportParts> parts;
  double scale = 1.0;     // image form: T = image / scale
  bool flat_mdf = false;  // add an MDF of distance 0 everywhere (a flat surface at the reference plane)
  std::string name;       // default: the input's file or folder name
  bool replace = false;   // replace an existing package at `out`

  core::CheckResult Check() const;
};

struct ImportBonnReport {
  bonn::BonnForm form = bonn::BonnForm::kDfmf;
  std::string signature;  // binary forms
  int rank = 0;           // components of the factored BTF written (0 if none)
  formats::MaterialManifest manifest;
  double seconds = 0.0;
};

// Reads `in` once and writes the package at `out` atomically. Throws
// FormatError / Error ("import bonn: ...") naming the file and field for bad
// input or options; nothing is written then.
ImportBonnReport RunImportBonn(const ImportBonnOptions& options);

}  // namespace mesocap::pipelines
