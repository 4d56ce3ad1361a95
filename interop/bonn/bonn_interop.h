// Interop with the Bonn BTF database: a material package's BTF exported to
// the UBO2003 image folder (core/bonn_ubo2003.h) or the UBO2014 binary FMF /
// DFMF files (core/bonn_btf_file.h), and those forms imported as a material
// package, so public BTFs can be processed and rendered by mesocap and
// mesocap's BTFs read by the tools that read those databases.
//
// How the data map (docs/FORMATS.md "Bonn BTF database forms"):
// - Directions: the same frame and angles (core/bonn_btf_file.h); index
//   orders are kept as the file has them (binary) or ring by ring (images).
// - Values: mesocap's linear RGB reflectance T, unscaled, = what btflib
//   decodes (after undoing the colour model, the dynamic-range reduction and,
//   when the cosine flag is set, dividing by cos theta_light). The RGB scale
//   factor of the meta data is not applied, as btflib does not apply it.
// - DFMF is the per-channel SVD of mesocap's per_texel layout (rows x, y;
//   columns view x light, column view * Nlight + light = btflib's
//   light + Nlight * view): a per_texel factored BTF is written as it is,
//   r_k = sigma_k u_k split into U = r_k / |r_k| and SxV = c_k |r_k|. The
//   colour channels are RGB (model 0) or, for mesocap's decorrelated
//   channels f = M rgb, the PCA model 3 with matrix (M^-1)^T and mean 0.
// - FMF factors one matrix whose rows are (channel, x, y): written from the
//   SVD (processing/btf_compression.h) of that matrix, read as a per_texel
//   factored BTF whose column factors are the same for the 3 channels.
// - Importing a factored file as mesocap's factored BTF is exact (up to
//   float rounding); a PCA mean becomes one extra component. Nonlinear
//   decodes (dynamic-range reduction, logarithmic colour models) can only
//   be imported as a full BTF, and only the linear colour models are read.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "btf/btf_compression.h"
#include "core/btf.h"
#include "core/error.h"
#include "formats/material_manifest.h"
#include "interop/bonn/bonn_btf_file.h"
#include "interop/bonn/bonn_ubo2003.h"

namespace mesocap::bonn {

enum class BonnForm { kUbo2003, kFmf, kDfmf };
const char* ToString(BonnForm form);  // "ubo2003", "fmf", "dfmf"

struct BonnExportOptions {
  BonnForm form = BonnForm::kDfmf;
  // ubo2003: image = T * scale, 8-bit sRGB PNG or linear half EXR.
  Ubo2003Encoding encoding = Ubo2003Encoding::kSrgb8Png;
  double scale = 1.0;
  // fmf, dfmf: factor values as half (what btflib writes) or float.
  BonnScalar scalar = BonnScalar::kHalf;
  // fmf, dfmf, when the package's BTF has to be factored here (always for
  // fmf; for dfmf unless the package holds a per_texel factored BTF): rank
  // or error budget, and for dfmf the colour channels. The layout is
  // per_texel whatever is set.
  btf::BtfCompressionOptions compression;
  bool replace = false;

  core::CheckResult Check() const;
};

struct BonnExportReport {
  std::string source;  // what was exported: "full BTF", "per_texel factored BTF", ...
  int rank = 0;        // components written (fmf, dfmf)
  std::optional<btf::BtfCompressionReport> compression;  // when factored here
  long long clipped_values = 0;                     // ubo2003 8-bit: values outside [0, 1] after scaling
  long long files = 0;
  double seconds = 0.0;
};

// Writes the BTF of the package at `package` to `out` (a folder for
// ubo2003, a file for fmf and dfmf), atomically: on any failure nothing is
// left at `out` and what was there is intact. Throws Error when the package
// holds no BTF or `out` exists and `replace` is false.
BonnExportReport ExportBonn(const std::filesystem::path& package, const std::filesystem::path& out,
                            const BonnExportOptions& options);

enum class BonnImportParts { kFactored, kFull, kBoth };

struct BonnImportOptions {
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
  bool replace = false;

  core::CheckResult Check() const;
};

struct BonnImportReport {
  BonnForm form = BonnForm::kDfmf;
  std::string signature;  // binary forms
  int rank = 0;           // components of the factored BTF written (0 if none)
  formats::MaterialManifest manifest;
  double seconds = 0.0;
};

// Reads the folder (UBO2003 images) or file (FMF, DFMF, told by its
// signature) at `in` and writes a material package at `out` with the BTF
// (full and/or factored), its ambient term (processing/ambient_term.h) and,
// when asked, a flat MDF; atomically. Throws FormatError / Error naming the
// file and field for bad input; nothing is written then.
BonnImportReport ImportBonn(const std::filesystem::path& in, const std::filesystem::path& out,
                            const BonnImportOptions& options);

// The conversions behind the above.
//
// A per_texel factored BTF as a DFMF (texel rows). Throws Error for the paper layout.
BonnBtfFile BonnDfmfFromFactored(const core::FactoredBtf& btf);
// The FMF of a full BTF: the SVD of the (channel, x, y) x (view, light)
// matrix by CompressBtf (per_texel, rgb) with `options`' rank or budget.
// Needs the BTF three times over in memory (the stacked channels).
BonnBtfFile BonnFmfFromFullBtf(const core::FullBtf& btf, const btf::BtfCompressionOptions& options,
                               btf::BtfCompressionReport* report = nullptr);
// A Bonn file's direction lists as sampling sets, in the file's order;
// named "ubo2014" or "ubo2003" when they are that set's directions (within
// the file's float rounding), which are then used exactly.
core::SamplingSet BonnViewSet(const BonnBtfFile& btf, const std::filesystem::path& file);
core::SamplingSet BonnLightSet(const BonnBtfFile& btf, const std::filesystem::path& file);
// The factored BTF a Bonn file holds (per_texel), exactly. Throws Error for
// a dynamic-range-reduced FMF, a nonlinear colour model, or more than
// kMaxBtfRank components.
core::FactoredBtf FactoredFromBonn(const BonnBtfFile& btf, const std::filesystem::path& file);
// View `view` decoded as btflib decodes it, as a full-BTF view image.
core::Image BonnBtfView(const BonnBtfFile& btf, int view);

}  // namespace mesocap::bonn
