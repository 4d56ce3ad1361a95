// The image form of the Bonn BTF database (UBO2003, Sattler, Sarlette and
// Klein 2003): a folder with one rectified texture image per (light, view)
// pair, the directions in the file name.
//
// Facts relied on:
// - Naming "tl<theta_l>_pl<phi_l>_tv<theta_v>_pv<phi_v>.<ext>", each angle in
//   whole degrees written with three digits ("tl015_pl060_tv030_pv090"), as
//   the UTIA BTF database documents it for compatibility with the Bonn
//   database (btf.utia.cas.cz, "Filename format"); the images of one view may
//   sit in a subfolder named "tv<theta_v>_pv<phi_v>" there.
// - btflib's image-folder reader (matlab/@btf/private/read_ubo_images.m)
//   takes the four angles in any of those token orders with decimals
//   ("tv(\d+\.?\d*)_pv..._tl..._pl..."), in degrees, and reads OpenEXR
//   (linear float) images only.
// - The 8-bit images are sRGB-encoded (UTIA: "PNG format (colour space sRGB
//   8-bits/channel)").
// - theta is the polar angle from the sample normal, phi the azimuth, in the
//   same frame as the binary forms (interop/bonn/bonn_btf_file.h): mesocap's frame.
//
// mesocap writes: whole degrees as three digits, other angles with up to six
// decimals ("tl005.625_..."); a flat folder; PNG 8-bit sRGB or OpenEXR half
// (linear). It reads: the four tokens in any order, whole or decimal degrees,
// PNG/TIFF (8 or 16 bit, sRGB-decoded) or OpenEXR (linear), from the folder
// and its direct subfolders.
//
// Values: image = T * scale (mesocap's linear reflectance T, no cosine
// factor, like a binary file with cosine flag 0), sRGB-encoded for the
// integer forms; reading divides by the same scale. The 8-bit form keeps
// [0, 1] only: values below 0 or above 1 after scaling are clipped (counted).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/image_io.h"
#include "core/sampling_set.h"

namespace mesocap::bonn {

// The range of an image form's scale (export and import --scale).
inline constexpr double kMinUbo2003Scale = 1e-6;
inline constexpr double kMaxUbo2003Scale = 1e6;

enum class Ubo2003Encoding { kSrgb8Png, kHalfExr };

// "tl015_pl060_tv030_pv090.png" (angles in degrees as described above).
std::string Ubo2003ImageName(const core::SphericalAngles& light, const core::SphericalAngles& view,
                             Ubo2003Encoding encoding);

// The images of a folder, validated from their names and headers only.
struct Ubo2003ImageSet {
  int width = 0;
  int height = 0;
  core::SamplingSet views;   // ring by ring from the pole, by increasing phi
  core::SamplingSet lights;  // "ubo2003" when the directions are that set's
  // files[view][light]
  std::vector<std::vector<std::filesystem::path>> files;
};

// Scans `dir` (and its direct subfolders) for image files named as above.
// Throws FormatError naming the file for a name that starts like one but
// does not parse, an angle out of range, two files for one (light, view)
// pair, a missing pair (naming the file expected), mixed extensions, and an
// image whose size or channel count (3) differs from the first; Error when
// no image is found.
Ubo2003ImageSet ScanUbo2003Folder(const std::filesystem::path& dir);

// Whether `dir` is a folder holding only what an export writes: image files
// named as above, nothing else (what `export bonn --replace` may replace).
bool IsUbo2003ExportFolder(const std::filesystem::path& dir);

// View `view` as a full-BTF view image (3 channels, W x H * Nlight, light l
// in rows [l*H, (l+1)*H)): linear, divided by `scale`.
core::Image ReadUbo2003View(const Ubo2003ImageSet& set, int view, double scale);

// Writes the Nlight images of view `view` (a full-BTF view image) into
// `dir`. Returns how many values fell outside [0, 1] after scaling and were
// clipped (8-bit form). Throws Error for a value that does not fit a half.
long long WriteUbo2003View(const std::filesystem::path& dir, const core::SamplingSet& views,
                           const core::SamplingSet& lights, int view, const core::Image& values,
                           Ubo2003Encoding encoding, double scale);

}  // namespace mesocap::bonn
