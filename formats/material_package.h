// The version-1 material package (docs/ARCHITECTURE.md "On disk"; docs/FORMATS.md
// "Material package"): a folder holding manifest.json and the image files of
// whichever parts the material has -- the MDF (float and 8-bit forms), the BTF
// (full and/or SVD-factored), the ambient term of Wang et al. 2005 Sec. 4.2
// and an error report. Any subset of parts is a valid package (a ground-truth
// MDF-only package, a BTF without geometry).
//
// This header holds the parts in memory. The manifest is in
// material_manifest.h, writing in material_package_writer.h, reading in
// material_package_reader.h and package_full_btf_reader.h (the full BTF a
// range of rows at a time).
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
#include <nlohmann/json.hpp>
#include <optional>

#include "core/btf.h"
#include "core/image.h"
#include "core/mdf.h"
#include "core/sampling_set.h"
#include "formats/material_manifest.h"

namespace mesocap::formats {

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

}  // namespace mesocap::formats
