// The binary BTF files of the Bonn BTF database (UBO2014 and later): the
// full-matrix-factorized form FMF ("!FMF12FCER") and the decorrelated form
// DFMF ("!DFMF08FCR"), read and written byte for byte as btflib
// (github.com/cgbonn/btflib, matlab/@btf/private/{read,write}_ubo_{fmf,dfmf}.m,
// {read,write}_common_header.m, {read,write}_meta_data.m,
// {read,write}_bidir_sampling.m) reads and writes them and as the Free BTF
// Library (github.com/zeroeffects/btf, btf.hh: LoadBTF) loads them.
// Re-implemented from the layout those readers document; no code taken
// from there.
//
// Facts relied on (docs/FORMATS.md "Bonn BTF files" has the full table):
// - Every number is little-endian (btflib reads with the machine's order on
//   x86); u32/i32 counts, f32 angles and header floats.
// - Signature, then a meta-data block whose first u32 is its own size in
//   bytes (btflib checks it), its version (1..4): three 80-char strings
//   (setup, sensor, light source), f32 pixels per mm, f32[3] RGB scale
//   factor, (v>1) u32 cosine flag, (v>2) u32 length + XML text, (v>3) u32
//   channel count + (u32 length + name) per channel.
// - Directions: u32 view count; per view f32 theta, f32 phi (radians, polar
//   angle from +z and azimuth atan2(y, x): btflib's cart2sph2/sph2cart2),
//   u32 light count and that many (f32 theta, f32 phi) -- the same light
//   list after every view (btflib refuses differing counts).
// - u32 width, u32 height; a signature ending in 'R' adds u32 rotation count
//   and 3x3 f32 matrices (read and skipped: btflib stores but never applies
//   them).
// - FMF: (signature "!FMF12FCER" only) u8 header version 0..2; >=1: u32
//   dynamic-range-reduction method (non-zero: the data are log(value + 1e-5),
//   btflib's restore_dynamic_range); >=2: u32[2] height-map size and that many
//   halfs (skipped). Then u32 component count, u8 scalar size (2 half,
//   4 float, 8 double), u32 component count again, u32 rows, u32 columns, the
//   singular values S, U (rows x K) and SxV (columns x K), both row-major.
//   The BTF matrix is A = U * SxV^T (the singular values are folded into
//   SxV; S is informational, as btflib's decoders never read it).
// - DFMF: u32 largest component count, i32 colour model, f32[3] colour mean,
//   f32[9] colour matrix (row-major), then per colour channel: u8 scalar
//   size, u32 component count, u32 rows, u32 columns, S, U, SxV as above.
// - Matrix orientation. The database's files (what the Free BTF Library,
//   github.com/zeroeffects/btf btf.hh, reads for btf-extractor) have U's
//   rows index directions (DFMF: light + Nlight * view; FMF: channel + 3 *
//   (light + Nlight * view)) and SxV's rows texels (x + W * y, x fastest,
//   row 0 the first image row). btf.hh requires U's rows = Nlight^2 (x 3
//   for FMF) and SxV's = W * H, so it reads only files with as many views
//   as lights, and refuses the other orientation. btflib's
//   decoders (decode_{fmf,dfmf}_{texture,abrdf}) also take the other way
//   round (U rows = texels, FMF: channel + 3 * texel), which mesocap wrote
//   before; the counts tell them apart, direction rows tested first.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/sampling_set.h"

namespace mesocap::bonn {

enum class BonnBtfForm { kFmf, kDfmf };

// Bytes per stored factor value: 2 half (what btflib writes), 4 float,
// 8 double (read only).
enum class BonnScalar : int { kHalf = 2, kFloat = 4, kDouble = 8 };

// What U's rows index; SxV's rows index the other. kDirections is the
// database's orientation.
enum class BonnRowSpace { kTexels, kDirections };

// DFMF colour models (btflib's undecorrelate.m). mesocap reads the linear ones.
inline constexpr int kBonnColorRgb = 0;
inline constexpr int kBonnColorYuv = 1;
inline constexpr int kBonnColorPca = 3;
inline constexpr int kBonnColorYcocg = 4;

// A direction as a Bonn file stores it: radians, theta from +z, phi =
// atan2(y, x) (any range; btflib writes (-pi, pi]).
struct BonnDirection {
  float theta = 0.0f;
  float phi = 0.0f;
};

// Bonn and mesocap use the same frame (+z out of the sample, phi from +X
// towards +Y, directions away from the surface), so the conversion is a
// wrap of phi into [0, 2 pi) (mesocap) or (-pi, pi] (Bonn) and the float
// rounding of the file (about 6e-8 rad).
core::SphericalAngles AnglesFromBonn(const BonnDirection& d);
BonnDirection BonnFromAngles(const core::SphericalAngles& a);

// A = U * SxV^T. Row-major as in the file.
using BonnMatrix = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
struct BonnFactors {
  Eigen::VectorXf singular_values;  // K
  BonnMatrix u;                     // rows x K
  BonnMatrix sxv;                   // columns x K
  int rank() const { return static_cast<int>(u.cols()); }
};

struct BonnBtfFile {
  BonnBtfForm form = BonnBtfForm::kDfmf;
  std::string signature;  // as read; the writer uses "!FMF12FCER" / "!DFMF08FCR"
  // Meta data.
  std::string measurement_setup;  // at most 80 bytes each
  std::string image_sensor;
  std::string light_source;
  float pixels_per_mm = 0.0f;
  Eigen::Vector3f rgb_scale_factor = Eigen::Vector3f::Ones();
  bool cosine_flag = false;  // data multiplied by cos(theta_light)
  std::string xml;
  std::vector<std::string> channel_names{"R", "G", "B"};
  std::vector<BonnDirection> views;
  std::vector<BonnDirection> lights;
  int width = 0;
  int height = 0;
  // FMF only: 0 none, else the data are log(value + 1e-5).
  std::uint32_t dynamic_range_reduction = 0;
  // DFMF only: rgb = M^T f + mean for the PCA model (btflib multiplies row
  // vectors: values * M); fixed matrices for YUV and YCoCg.
  std::int32_t color_model = kBonnColorRgb;
  Eigen::Vector3f color_mean = Eigen::Vector3f::Zero();
  Eigen::Matrix3f color_matrix = Eigen::Matrix3f::Identity();
  // FMF: one entry (channels inside the matrix); DFMF: one per channel.
  BonnRowSpace row_space = BonnRowSpace::kDirections;
  std::vector<BonnFactors> factors;
  BonnScalar scalar = BonnScalar::kHalf;  // as read (the first channel's, for DFMF)

  int view_count() const { return static_cast<int>(views.size()); }
  int light_count() const { return static_cast<int>(lights.size()); }
};

// Reads and validates a whole file: signature, every count against the
// others and against the file's size before anything is allocated, the
// meta block's size, the matrix sizes against width, height and the
// direction counts (either orientation; when width x height equals views x
// lights the counts cannot tell, and U's rows are taken as directions, the
// database's orientation and what every mesocap export writes then), and no
// bytes past the end of the data. Accepts the signatures btflib does for FMF
// ("!FMF12FCER", "!FMF06FCR", "!FMF06FC") and DFMF ("!DFMF08FCR"). Only 3
// colour channels (RGB) are accepted. Throws FormatError naming the file,
// the field and what was expected.
BonnBtfFile ReadBonnBtfFile(const std::filesystem::path& file);

// Whether `file` is a regular file that starts with the signature of one of
// the forms above (what `export bonn --replace` may replace).
bool IsBonnBtfFile(const std::filesystem::path& file);

// Writes "!FMF12FCER" (header version 2, no height map) or "!DFMF08FCR" with
// meta version 4 and no rotations, atomically, in the orientation
// `btf.row_space` gives (mesocap's exports build the database's). Throws
// Error on inconsistent sizes or when a value does not fit `scalar` (half:
// |v| <= 65504). When width x height equals views x lights readers take
// U's rows as directions: a texel-rows DFMF is then written transposed (U
// and SxV swapped), a texel-rows FMF refused.
void WriteBonnBtfFile(const std::filesystem::path& file, const BonnBtfFile& btf, BonnScalar scalar);

// rgb = to_rgb * f + offset for the decorrelated channels f of a linear
// DFMF colour model (btflib's undecorrelate.m): RGB (identity), YUV and
// YCoCg (fixed matrices), PCA (the file's matrix transposed, plus its mean;
// the mean is used by PCA only). An FMF is RGB. Throws Error naming the
// model for the others (LAB, spectral, logarithmic), which are not linear.
struct BonnColorTransform {
  Eigen::Matrix3d to_rgb = Eigen::Matrix3d::Identity();
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
};
BonnColorTransform BonnToRgb(const BonnBtfFile& btf);
// "RGB", "YUV", "LAB", "PCA", "YCoCg", ... or "unknown".
const char* BonnColorModelName(int model);

}  // namespace mesocap::bonn
