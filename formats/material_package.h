// The version-1 material package (DESIGN.md "On disk"; docs/FORMATS.md
// "Material package"): a folder holding manifest.json and the image files of
// whichever parts the material has -- the MDF (float and 8-bit forms), the BTF
// (full and/or SVD-factored), the ambient term of Wang et al. 2005 Sec. 4.2
// and an error report. Any subset of parts is a valid package (a ground-truth
// MDF-only package, a BTF without geometry).
//
// Writing is atomic: the folder is built under a temporary name and renamed
// into place (AtomicDirectory), so a failure leaves no partial output and the
// package that was there before intact. Reading validates the manifest first
// (ReadMaterialManifest: fields, units, sizes, that every file exists) without
// touching pixel data; each part reader then checks its files' sizes against
// the manifest before allocating anything. Every problem with a file is a
// FormatError naming the file, the field and what was expected.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/btf.h"
#include "core/image.h"
#include "core/image_io.h"
#include "core/mdf.h"
#include "core/sampling_set.h"
#include "formats/calibration.h"

namespace mesocap::formats {

// Limits a manifest must respect; beyond them it is refused as implausible
// before anything is allocated.
inline constexpr int kMaxTextureSize = 16384;                 // texels per side
inline constexpr int kMaxDirections = 10000;                  // per sampling set (view_<v:04d> names)
inline constexpr double kMaxPartBytes = 64.0 * (1ull << 30);  // float data one part implies

struct MaterialProvenance {
  std::string software_version;  // mesocap version that made the data
  std::string created_utc;       // ISO 8601, e.g. "2025-01-31T18:04:05Z"
  std::string source;            // free text: "groundtruth scene=weave rig=small", a session path
};

// What every package states, whichever parts it holds.
struct MaterialDescription {
  std::string name;
  int width = 0;                               // texels along x, 1..kMaxTextureSize
  int height = 0;                              // texels along y
  Eigen::Vector2d physical_size_mm{0.0, 0.0};  // of the clipped square the texels cover, > 0
  double d_max_mm = 0.0;                       // mesostructure occupies -d_max <= z <= 0, > 0
  core::SamplingSet view_directions;                 // of the MDF, the BTF and the ambient term
  core::SamplingSet light_directions;                // of the BTF
  MaterialProvenance provenance;
};

// The ambient term La(x, y, view) of Sec. 4.2: the BTF integrated over the
// light hemisphere, used to shade points in macroscale shadow. Linear RGB,
// BTF units times steradians. Stored like the MDF: W wide, H * Nview tall,
// view v in rows [v*H, (v+1)*H).
struct AmbientTerm {
  int width = 0;
  int height = 0;
  core::SamplingSet views;
  core::Image values;  // 3 channels, width x height * views.size()

  int view_count() const { return views.size(); }
  Eigen::Vector3f at(int x, int y, int view) const {
    const float* p = values.pixel(x, view * height + y);
    return {p[0], p[1], p[2]};
  }
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
  };

  MaterialDescription description;
  std::optional<MdfPart> mdf;
  bool full_btf = false;
  std::optional<FactoredBtfPart> factored_btf;
  bool ambient = false;
  bool error_report = false;
  bool calibration = false;  // calibration.json: the rig the material was captured with
};

// A whole material in memory (small materials, tests, ground truth). Large
// BTFs go through MaterialPackageWriter view by view instead.
struct MaterialPackage {
  MaterialDescription description;
  std::optional<core::Mdf> mdf;
  MdfForms mdf_forms;
  std::optional<core::FullBtf> full_btf;
  std::optional<core::FactoredBtf> factored_btf;
  std::optional<AmbientTerm> ambient;
  std::optional<nlohmann::json> error_report;  // a JSON object
};

// Builds a package part by part in a temporary folder beside `dir`; Commit()
// writes the manifest and renames the folder into place. Destroyed without
// Commit() (an exception, a cancelled run), it leaves nothing behind and the
// old package untouched. Every part is checked against the description
// (sizes, direction sets, value encodings) when it is written; a bad part
// throws Error.
class MaterialPackageWriter {
 public:
  // Throws Error when `dir` exists and `replace` is false, or when the
  // description is invalid. Empty provenance.software_version and
  // created_utc are filled in with Version() and the current time.
  MaterialPackageWriter(const std::filesystem::path& dir, MaterialDescription description, bool replace);

  void WriteMdf(const core::Mdf& mdf, MdfForms forms = {});
  // A measured MDF's per-texel confidence in [0, 1] (issue 4: the share of a
  // view's scan weight that agrees on the texel; 0 where the MDF is unknown),
  // 1 channel in the MDF's layout. After WriteMdf.
  void WriteMdfConfidence(const core::Image& confidence);
  // One view of the full BTF: 3 channels, width x height * Nlight (light l
  // in rows [l*H, (l+1)*H)). Views may come in any order; all must be
  // written before Commit() once one is.
  void WriteFullBtfView(int view, const core::Image& values);
  // The full BTF written so far, read back from the files (PackageFullBtfReader),
  // e.g. to factor a BTF too large for memory; throws Error until every view
  // is written. Valid while the writer lives.
  std::unique_ptr<core::FullBtfReader> ReadBackFullBtf() const;
  void WriteFactoredBtf(const core::FactoredBtf& btf);
  void WriteAmbientTerm(const AmbientTerm& ambient);
  void WriteErrorReport(const nlohmann::json& report);
  // The calibration of the rig that captured the material (for ground truth,
  // the true one), as calibration.json beside the manifest.
  void WriteCalibration(const Calibration& calibration);

  // Writes manifest.json, re-reads it as a reader would, and moves the
  // package into place. Returns the manifest.
  MaterialManifest Commit();

  const MaterialDescription& description() const { return manifest_.description; }

 private:
  void ExpectOpen() const;

  std::filesystem::path dir_;
  core::AtomicDirectory folder_;
  MaterialManifest manifest_;
  std::vector<bool> full_btf_views_written_;
  bool committed_ = false;
};

// All of `package` in one go.
void WriteMaterialPackage(const std::filesystem::path& dir, const MaterialPackage& package, bool replace);

// Validates manifest.json (format, version, units, every field's type and
// range, implied sizes) and that every file it references exists. Reads no
// pixel data.
MaterialManifest ReadMaterialManifest(const std::filesystem::path& dir);

// Part readers. Each throws FormatError when the manifest has no such part,
// a file's size, channel count or pixel type differs from what the manifest
// implies (checked before allocating), or a value is not a valid encoding.
//
// The float form if present, else the 8-bit form decoded (within scale/2).
core::Mdf ReadMdf(const std::filesystem::path& dir, const MaterialManifest& manifest);
// The per-texel confidence (see WriteMdfConfidence); FormatError for a
// value outside [0, 1].
core::Image ReadMdfConfidence(const std::filesystem::path& dir, const MaterialManifest& manifest);
// The 8-bit form as stored (what a renderer uploads as a 3D texture).
core::QuantizedMdf ReadQuantizedMdf(const std::filesystem::path& dir, const MaterialManifest& manifest);
// One view of the full BTF (see WriteFullBtfView for the layout).
core::Image ReadFullBtfView(const std::filesystem::path& dir, const MaterialManifest& manifest, int view);
core::FullBtf ReadFullBtf(const std::filesystem::path& dir, const MaterialManifest& manifest);
// The package's full BTF read from its view files a range of rows at a time
// (core/btf.h: FullBtfReader), so a pass over it never holds the whole BTF.
// Keeps each view's file open between reads (up to kMaxOpenViews views; with
// more, each read opens and closes its file); FormatError (naming the file)
// for a view file of another size, channel count or pixel type, or a
// truncated one.
class PackageFullBtfReader : public core::FullBtfReader {
 public:
  static constexpr int kMaxOpenViews = 256;
  // Throws FormatError when the manifest has no full BTF.
  PackageFullBtfReader(const std::filesystem::path& dir, const MaterialManifest& manifest);
  // The view files under `dir`/btf of a package being written.
  PackageFullBtfReader(const std::filesystem::path& dir, const MaterialDescription& description);
  ~PackageFullBtfReader() override;

 protected:
  std::string Source(int view) const override;
  void ReadRowsFromSource(int view, int first_row, int rows, float* out) override;

 private:
  std::unique_ptr<core::ImageRowReader> Open(int view) const;

  std::filesystem::path dir_;
  std::vector<std::unique_ptr<core::ImageRowReader>> open_;  // per view; null until first read
  std::vector<std::mutex> view_mutex_;                 // guards open_[view] and its reads
};
core::FactoredBtf ReadFactoredBtf(const std::filesystem::path& dir, const MaterialManifest& manifest);
AmbientTerm ReadAmbientTerm(const std::filesystem::path& dir, const MaterialManifest& manifest);
nlohmann::json ReadErrorReport(const std::filesystem::path& dir, const MaterialManifest& manifest);
Calibration ReadPackageCalibration(const std::filesystem::path& dir, const MaterialManifest& manifest);
// Everything, in memory.
MaterialPackage ReadMaterialPackage(const std::filesystem::path& dir);

// File names inside a package, relative to its folder.
std::filesystem::path FullBtfViewFile(int view);  // "btf/view_0007.exr"
std::filesystem::path BtfRowFactorFile(int k);    // "btf/rows_03.exr"

}  // namespace mesocap::formats
