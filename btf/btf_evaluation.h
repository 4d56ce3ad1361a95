// Error of an estimated BTF against the true one (the simulated rig's exact
// texture-space BTF, sim/ground_truth.h), view by view so neither has to be
// in memory at once: relative RMS error ||T - E||_F / ||T||_F and PSNR
// 10 log10(peak^2 / MSE), overall and in bands of the view's polar angle
// (grazing views are where rectification and radiometry are hardest).
// The PSNR peak is the largest true value over everything added, the same
// for every band, so bands compare with each other.
//
// A measured BTF mixes three kinds of value, and one overall figure hides
// which dominates: pairs an image captured, pairs interpolated from a view's
// captured lights (directions 30 to 90 degrees away on the small rig), and
// views whose texels are finer than a camera pixel (detail interpolated, not
// resolved). The assembly records which is which (BtfPairRecord); the
// figures are then given for each apart.
#pragma once

#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/btf.h"
#include "core/image.h"
#include "core/sampling_set.h"

namespace mesocap::btf {

struct BtfErrorFigures {
  double psnr_db = 0.0;       // +infinity when the estimate is exact
  double relative_rms = 0.0;  // 0 when both are zero
  long long values = 0;       // RGB values compared
};

// What the assembly of a measured BTF recorded about its pairs (`process
// btf`'s error report, "btf_assembly"): which (view, light) pairs an image
// captured, and the narrowest texel footprint in camera pixels of each view
// (below 1 the view's texels are not resolved).
struct BtfPairRecord {
  std::vector<std::vector<bool>> captured;  // [view][light]
  std::vector<double> pixels_per_texel;     // [view]
  bool resolved(int view) const { return pixels_per_texel[view] >= 1.0; }
};

// The members "captured" (one array of booleans per view) and
// "pixels_per_texel" (one number per view) of an object.
void AddPairRecord(const BtfPairRecord& record, nlohmann::json* object);
// The record in `object` (an error report's "btf_assembly"), or nothing when
// it holds none; throws FormatError naming `file` and the field when the
// record is there but malformed or sized for other direction sets.
std::optional<BtfPairRecord> ReadPairRecord(const nlohmann::json& object, const std::filesystem::path& file, int views,
                                            int lights);

class BtfErrorAccumulator {
 public:
  // Bands [k * band_deg, (k + 1) * band_deg) of the view polar angle.
  BtfErrorAccumulator(core::SamplingSet views, core::SamplingSet lights, double band_deg = 15.0);

  // One view: truth and estimate are full-BTF view images of equal size, one
  // slice of equal height per light. Throws Error on a size mismatch or a
  // non-finite estimate value.
  void Add(int view, const core::Image& truth, const core::Image& estimate);

  // Over every view added with theta <= theta_max_deg (all by default).
  BtfErrorFigures Overall(double theta_max_deg = 90.0) const;
  // Over the pairs `include` accepts.
  BtfErrorFigures Over(const std::function<bool(int view, int light)>& include) const;
  struct Band {
    double theta_min_deg = 0.0;
    double theta_max_deg = 0.0;
    BtfErrorFigures figures;
  };
  // The non-empty bands, in order.
  std::vector<Band> ByPolarAngle() const;
  double peak() const { return peak_; }
  const core::SamplingSet& views() const { return views_; }
  const core::SamplingSet& lights() const { return lights_; }

 private:
  struct Sums {
    double error = 0.0;  // sum of squared differences
    double truth = 0.0;  // sum of squared true values
    long long values = 0;
  };
  BtfErrorFigures Figures(const Sums& s) const;

  core::SamplingSet views_;
  core::SamplingSet lights_;
  double band_deg_;
  std::vector<Sums> per_pair_;  // [view * lights + light]
  double peak_ = 0.0;
};

// `mesocap eval btf --json`: {"overall": {"psnr_db", "relative_rms"},
// "by_polar_angle": [{"theta_min_deg", "theta_max_deg", "psnr_db",
// "relative_rms"}, ...], "rank": K or null (a full estimate), "peak"}, and
// with a pair record, for the pairs of each kind, {"pairs", "psnr_db",
// "relative_rms"}: "captured" and "interpolated" (of the views whose texels
// the cameras resolve), "unresolved" (every pair of the other views, plus
// their count "views"), and "captured_within_60deg" (captured and resolved,
// view and light within 60 degrees of the normal); without one, those four
// are null. An infinite PSNR (exact estimate) is written as null.
nlohmann::json ToJson(const BtfErrorAccumulator& errors, std::optional<int> rank,
                      const std::optional<BtfPairRecord>& pairs = std::nullopt);

}  // namespace mesocap::btf
