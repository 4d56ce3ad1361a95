// The manifest of a material package (material_package.h; docs/FORMATS.md
// "Material package"): what every package states -- its texel grid, physical
// size, d_max, direction sets and provenance -- and which parts it holds.
// ReadMaterialManifest validates it without touching pixel data; the writer
// (material_package_writer.h) writes it when it commits the package.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/btf.h"
#include "core/file_checksum.h"
#include "core/image.h"
#include "core/sampling_set.h"

namespace mesocap::formats {

// Limits a manifest must respect besides core::kMaxImageSide texels per side;
// beyond them it is refused as implausible before anything is allocated.
inline constexpr int kMaxDirections = 10000;                  // per sampling set (view_<v:04d> names)
inline constexpr double kMaxPartBytes = 64.0 * (1ull << 30);  // float data one part implies
inline constexpr int kMaxTexelSamplesPerSide = 64;            // provenance.texel_samples_per_side

struct MaterialProvenance {
  std::string software_version;  // mesocap version that made the data
  std::string created_utc;       // ISO 8601, e.g. "2025-01-31T18:04:05Z"
  std::string source;            // free text: "groundtruth scene=weave rig=small", a session path
  // Ground truth: its BTF and ambient term are each texel's mean over n x n
  // stratified samples of the texel's area (sim/ground_truth.h); 0 where
  // the package does not say (measured materials, older packages).
  int texel_samples_per_side = 0;
};

// What every package states, whichever parts it holds.
struct MaterialDescription {
  std::string name;
  int width = 0;                               // texels along x, 1..core::kMaxImageSide
  int height = 0;                              // texels along y
  Eigen::Vector2d physical_size_mm{0.0, 0.0};  // of the clipped square the texels cover, > 0
  double d_max_mm = 0.0;                       // mesostructure occupies -d_max <= z <= 0, > 0
  core::SamplingSet view_directions;           // of the MDF, the BTF and the ambient term
  core::SamplingSet light_directions;          // of the BTF
  MaterialProvenance provenance;
};

// Which stored forms of the MDF a package holds (at least one).
struct MdfForms {
  bool float32 = true;  // mdf.exr: exact
  bool uint8 = true;    // mdf8.tif: Sec. 5's 8-bit form, within scale/2
};

// The validated manifest: the description and which parts are present.
struct MaterialManifest {
  struct MdfPart {
    MdfForms forms;
    double scale_mm = 0.0;    // of the 8-bit form; 0 when there is none
    bool confidence = false;  // mdf_confidence.exr: a measured MDF's per-texel confidence
  };
  struct FactoredBtfPart {
    core::BtfFactorLayout layout = core::BtfFactorLayout::kPaper;
    core::BtfFactorColor color = core::BtfFactorColor::kRgb;
    Eigen::Matrix3d rgb_to_factored = Eigen::Matrix3d::Identity();
    int rank = 0;
    int clusters = 1;  // clustered layout only
  };

  MaterialDescription description;
  std::optional<MdfPart> mdf;
  bool full_btf = false;
  std::optional<FactoredBtfPart> factored_btf;
  bool ambient = false;
  bool error_report = false;
  bool calibration = false;  // calibration.json: the rig the material was captured with

  int version = 2;  // of the manifest read; version 1 has no checksums
  // Size and hash of every data file above, by name in the package ("mdf.exr",
  // "btf/view_0003.exr"); empty for a version 1 package. The writer fills it.
  std::map<std::string, core::FileChecksum> checksums;
};

// Validates manifest.json (format, version, units, every field's type and
// range, implied sizes, a checksum for every file it references) and that
// every such file exists. Reads no pixel data and hashes nothing.
MaterialManifest ReadMaterialManifest(const std::filesystem::path& dir);

// The data files the manifest references, by name in the package, in the
// manifest's order.
std::vector<std::string> PackageDataFiles(const MaterialManifest& manifest);
// Throws FormatError(file, "checksum") when the package file `name` no longer
// has the size and hash the manifest records (nothing to check for version 1).
void ExpectPackageFileIntact(const std::filesystem::path& dir, const MaterialManifest& manifest,
                             const std::string& name);
// Whether `dir` holds a material package: a manifest.json of this format
// (valid or not otherwise). What --replace of a package-writing command may replace.
bool IsMaterialPackageFolder(const std::filesystem::path& dir);

// File names inside a package, relative to its folder.
std::filesystem::path FullBtfViewFile(int view);  // "btf/view_0007.exr"
std::filesystem::path BtfRowFactorFile(int k);    // "btf/rows_03.exr"

}  // namespace mesocap::formats
