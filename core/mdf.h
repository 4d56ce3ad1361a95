// The mesostructure distance function (MDF) of Wang et al. 2005, Sec. 3:
// D(x, y, view) is the distance in mm from the reference-plane point p(x, y)
// along -view to the first mesostructure hit (docs/ARCHITECTURE.md "Conventions of the
// data"). Two special values are never confused with a distance:
//   no hit:  the ray leaves the slab -d_max <= z <= 0 without a hit;
//   unknown: the texel was not measured for that view.
//
// In memory (float) they are encoded as
//   no hit  = +infinity       (IsNoHit)
//   unknown = a quiet NaN     (IsUnknown; any NaN reads as unknown)
// so that comparisons with distances fail safely and the float file form
// (OpenEXR keeps both) is the memory form. The 8-bit form of Sec. 5 has its
// own codes (QuantizedMdf).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/image.h"
#include "core/sampling_set.h"

namespace mesocap::core {

inline float MdfNoHit() { return std::numeric_limits<float>::infinity(); }
inline float MdfUnknown() { return std::numeric_limits<float>::quiet_NaN(); }
inline bool IsNoHit(float d) { return std::isinf(d) && d > 0; }
inline bool IsUnknown(float d) { return std::isnan(d); }
// A distance (finite, >= 0), no hit or unknown. Negative distances and
// -infinity are not MDF values.
inline bool IsValidMdfValue(float d) { return IsUnknown(d) || IsNoHit(d) || (std::isfinite(d) && d >= 0); }

// The MDF sampled on a W x H texel grid and a set of view directions. The
// distances are stored as the paper's 3D texture (Sec. 5) flattened into one
// image: W wide, H * Nview tall, view v in rows [v*H, (v+1)*H). This is also
// exactly the layout of the float file mdf.exr.
struct Mdf {
  int width = 0;
  int height = 0;
  SamplingSet views;
  Image distance_mm;  // 1 channel, width x height * views.size()

  int view_count() const { return views.size(); }
  float& at(int x, int y, int view) { return distance_mm.at(x, view * height + y); }
  float at(int x, int y, int view) const { return distance_mm.at(x, view * height + y); }
};

// An MDF of the given size with every value unknown.
Mdf MakeMdf(int width, int height, SamplingSet views);

// The 8-bit form (Sec. 5: "MDF depth data are quantized to 8 bits per pixel").
// Same layout as Mdf::distance_mm. A distance D is stored as the code
// round(D / scale_mm) clamped to 0..253; 254 is no hit, 255 unknown.
struct QuantizedMdf {
  static constexpr std::uint8_t kMaxDistanceCode = 253;
  static constexpr std::uint8_t kNoHitCode = 254;
  static constexpr std::uint8_t kUnknownCode = 255;

  int width = 0;
  int height = 0;
  SamplingSet views;
  double scale_mm = 0.0;            // mm per code step, > 0
  std::vector<std::uint8_t> codes;  // width * height * views.size(), row-major

  std::uint8_t at(int x, int y, int view) const {
    return codes[(static_cast<std::size_t>(view) * height + y) * width + x];
  }
};

// The step that maps the largest finite distance to code 253, so that every
// distance is stored within scale/2; d_max_mm / 253 when no distance is
// positive (an all-no-hit MDF still gets a usable scale).
double MdfQuantizationScale(const Mdf& mdf, double d_max_mm);

// Throws Error on an invalid value (see IsValidMdfValue) or a bad d_max.
QuantizedMdf QuantizeMdf(const Mdf& mdf, double d_max_mm);
// Throws Error on a non-positive scale or a code count that does not match.
Mdf DequantizeMdf(const QuantizedMdf& quantized);

}  // namespace mesocap::core
