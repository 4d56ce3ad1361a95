// The Bonn export job (`mesocap export bonn`): a material package's BTF
// written in a Bonn BTF database form, the UBO2003 image folder or a UBO2014
// FMF / DFMF file, through the conversions of interop/bonn/ (how the data
// map is told in interop/bonn/bonn_interop.h).
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "btf/btf_compression.h"
#include "core/error.h"
#include "interop/bonn/bonn_btf_file.h"
#include "interop/bonn/bonn_interop.h"
#include "interop/bonn/bonn_ubo2003.h"

namespace mesocap::pipelines {

struct ExportBonnOptions {
  std::filesystem::path in;   // material package holding a BTF (full or factored)
  std::filesystem::path out;  // a folder for ubo2003, a file for fmf and dfmf
  bonn::BonnForm form = bonn::BonnForm::kDfmf;
  // ubo2003: image = T * scale, 8-bit sRGB PNG or linear half EXR.
  bonn::Ubo2003Encoding encoding = bonn::Ubo2003Encoding::kSrgb8Png;
  double scale = 1.0;
  // fmf, dfmf: factor values as half (what btflib writes) or float.
  bonn::BonnScalar scalar = bonn::BonnScalar::kHalf;
  // fmf, dfmf, when the package's BTF has to be factored here (always for
  // fmf; for dfmf unless the package holds a per_texel factored BTF): rank
  // or error budget, and for dfmf the colour channels. The layout is
  // per_texel whatever is set.
  btf::BtfCompressionOptions compression;
  bool replace = false;  // replace an existing file or folder at `out`

  core::CheckResult Check() const;
};

struct ExportBonnReport {
  std::string source;                                    // what was exported: "full BTF", "per_texel factored BTF", ...
  int rank = 0;                                          // components written (fmf, dfmf)
  std::optional<btf::BtfCompressionReport> compression;  // when factored here
  long long clipped_values = 0;                          // ubo2003 8-bit: values outside [0, 1] after scaling
  long long files = 0;
  double seconds = 0.0;
};

// Writes the BTF of the package at `in` to `out` atomically: on any failure
// nothing is left at `out` and what was there is intact. Throws Error
// ("export bonn: ...") for bad options, when the package holds no BTF, or
// when `out` exists and `replace` is false.
ExportBonnReport RunExportBonn(const ExportBonnOptions& options);

}  // namespace mesocap::pipelines
