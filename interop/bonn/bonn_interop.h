// Interop with the Bonn BTF database: the conversions between mesocap's BTF
// values and the UBO2014 binary FMF / DFMF files (bonn_btf_file.h), behind
// the export and import jobs (pipelines/export_bonn.h, pipelines/import_bonn.h)
// that write a material package's BTF in those forms or the UBO2003 image
// folder (bonn_ubo2003.h) and read them back, so public BTFs can be processed
// and rendered by mesocap and mesocap's BTFs read by the tools that read
// those databases.
//
// How the data map (docs/FORMATS.md "Bonn BTF database forms"):
// - Directions: the same frame and angles (interop/bonn/bonn_btf_file.h); index
//   orders are kept as the file has them (binary) or ring by ring (images).
// - Values: mesocap's linear RGB reflectance T, unscaled, = what btflib
//   decodes (after undoing the colour model, the dynamic-range reduction and,
//   when the cosine flag is set, dividing by cos theta_light). The RGB scale
//   factor of the meta data is not applied, as btflib does not apply it.
// - Both files are written in the database's orientation (U's rows
//   directions, SxV's rows texels: bonn_btf_file.h); both orientations are
//   read.
// - DFMF is the per-channel SVD of mesocap's per_texel layout (rows x, y;
//   columns view x light, column view * Nlight + light = btflib's
//   light + Nlight * view): a per_texel factored BTF is written as it is,
//   r_k c_k^T split into U = c_k / |c_k| and SxV = r_k |c_k|. The colour
//   channels are RGB (model 0) or, for mesocap's decorrelated channels
//   f = M rgb, the PCA model 3 with matrix (M^-1)^T and mean 0.
// - FMF factors one matrix whose rows are (channel, light, view) and
//   columns (x, y): written from the SVD (btf/btf_compression.h) of that
//   matrix, read as a per_texel factored BTF whose row factors (textures)
//   are the same for the 3 channels (or, for a file with texel rows
//   (channel, x, y), whose column factors are).
// - Importing a factored file as mesocap's factored BTF is exact (up to
//   float rounding); a PCA mean becomes one extra component. Nonlinear
//   decodes (dynamic-range reduction, logarithmic colour models) can only
//   be imported as a full BTF, and only the linear colour models are read.
#pragma once

#include <filesystem>
#include <string>

#include "btf/btf_compression.h"
#include "core/btf.h"
#include "core/enum_text.h"
#include "core/error.h"
#include "interop/bonn/bonn_btf_file.h"

namespace mesocap::bonn {

// The forms a package's BTF is exported to or imported from.
enum class BonnForm { kUbo2003, kFmf, kDfmf };
constexpr auto EnumNamesOf(BonnForm) { return std::to_array({"ubo2003", "fmf", "dfmf"}); }
using core::ToString;

// A per_texel factored BTF as a DFMF (direction rows). Throws Error for the paper layout.
BonnBtfFile BonnDfmfFromFactored(const core::FactoredBtf& btf);
// The FMF of a full BTF (direction rows): the SVD of the (channel, light,
// view) x (x, y) matrix by CompressBtf (per_texel, rgb) with `options`'
// rank or budget, at most min(kMaxBtfRank, W H, 3 Nview Nlight)
// components. Needs the BTF three times over in memory (the stacked
// channels).
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
