// Writing a material package (material_package.h): part by part with
// MaterialPackageWriter, or a whole MaterialPackage in one go.
#pragma once

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <vector>

#include "core/atomic_file.h"
#include "core/btf.h"
#include "core/image.h"
#include "core/mdf.h"
#include "formats/calibration.h"
#include "formats/material_manifest.h"
#include "formats/material_package.h"

namespace mesocap::formats {

// Builds a package part by part in a temporary folder beside `dir`; Commit()
// writes the manifest and renames the folder into place. Destroyed without
// Commit() (an exception, a cancelled run), it leaves nothing behind and the
// old package untouched. Every part is checked against the description
// (sizes, direction sets, value encodings) when it is written; a bad part
// throws Error.
class MaterialPackageWriter {
 public:
  // Throws Error when `dir` exists and `replace` is false, when it holds
  // anything but a material package or holds one of `inputs` (the command's
  // inputs, never replaced), or when the description is invalid. Empty
  // provenance.software_version and created_utc are filled in with
  // Version() and the current time.
  MaterialPackageWriter(const std::filesystem::path& dir, MaterialDescription description, bool replace,
                        std::vector<std::filesystem::path> inputs = {});

  void WriteMdf(const core::Mdf& mdf, MdfForms forms = {});
  // A measured MDF's per-texel confidence in [0, 1] (the share of a view's
  // scan weight that agrees on the texel; 0 where the MDF is unknown), 1
  // channel in the MDF's layout. After WriteMdf.
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

  // Records every data file's size and hash, writes manifest.json, re-reads
  // it as a reader would, and moves the package into place. Returns the
  // manifest.
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

// The --replace rule of a command that writes a package at `dir`: only a
// material package is replaced, never one of the command's `inputs`.
core::OutputReplacement PackageReplacement(bool replace, std::vector<std::filesystem::path> inputs = {});

// All of `package` in one go.
void WriteMaterialPackage(const std::filesystem::path& dir, const MaterialPackage& package, bool replace,
                          std::vector<std::filesystem::path> inputs = {});

}  // namespace mesocap::formats
