// The error of a measured MDF against the truth (`mesocap eval mdf`): per
// polar-angle bucket and overall, the median and 95th percentile of
// |D - D_true| in mm and texel widths over texel-directions where both have
// a distance, the coverage (share of true hits with a measured distance),
// the false "no hit" rate (true hits measured as no hit), the false hit
// rate (true no-hits measured as a distance) and the no-hit coverage (true
// no-hits measured as no hit).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/mdf.h"

namespace mesocap::mdf {

struct MdfErrorRow {
  double theta_min_deg = 0;
  double theta_max_deg = 90;
  double median_mm = 0, p95_mm = 0;  // NaN when nothing was compared
  double median_texels = 0, p95_texels = 0;
  double coverage = 0;           // NaN when the truth has no hit here
  double false_no_hit_rate = 0;  // NaN when the truth has no hit here
  double false_hit_rate = 0;     // NaN when the truth has no "no hit" here
  double no_hit_coverage = 0;    // true no-hits measured as no hit; NaN when the truth has none
  long long true_hits = 0;       // texel-directions with a hit in the truth
  long long true_no_hits = 0;
  long long compared = 0;  // with a distance in both
};

struct MdfErrorTable {
  MdfErrorRow overall;
  std::vector<MdfErrorRow> by_polar_angle;  // [0, 15), [15, 30), ... [75, 90] degrees
};

// Which texel-directions count. The exact MDF is computed on the infinitely
// tiled mesostructure, while on the rig the sample sits in a pocket: a true
// hit whose point lies horizontally outside the sample square is behind the
// pocket wall and cannot be measured. inside_sample_only leaves those out
// (the grid spans the square: sample size = texel_mm x width).
struct MdfEvaluationScope {
  double theta_min_deg = 0;
  double theta_max_deg = 90;  // closed: 60 degrees counts as "up to 60"
  bool inside_sample_only = false;
};

MdfErrorRow EvaluateMdfViews(const core::Mdf& truth, const core::Mdf& estimate, double texel_mm,
                             const MdfEvaluationScope& scope);
// Throws Error when the two differ in texel grid or view directions (to 1e-6 rad).
MdfErrorTable EvaluateMdf(const core::Mdf& truth, const core::Mdf& estimate, double texel_mm,
                          bool inside_sample_only = false);

// {"overall": {...}, "by_polar_angle": [{...}, ...]}, NaN as null.
nlohmann::json ToJson(const MdfErrorTable& table);
// A fixed-width text table for people.
std::string FormatMdfErrorTable(const MdfErrorTable& table);

}  // namespace mesocap::mdf
