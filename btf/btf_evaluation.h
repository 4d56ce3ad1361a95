// Error of an estimated BTF against the true one (the simulated rig's exact
// texture-space BTF, sim/ground_truth.h), view by view so neither has to be
// in memory at once: relative RMS error ||T - E||_F / ||T||_F and PSNR
// 10 log10(peak^2 / MSE), overall and in bands of the view's polar angle
// (grazing views are where rectification and radiometry are hardest).
// The PSNR peak is the largest true value over everything added, the same
// for every band, so bands compare with each other.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
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

class BtfErrorAccumulator {
 public:
  // Bands [k * band_deg, (k + 1) * band_deg) of the view polar angle.
  explicit BtfErrorAccumulator(core::SamplingSet views, double band_deg = 15.0);

  // One view: truth and estimate are full-BTF view images of equal size.
  // Throws Error on a size mismatch or a non-finite estimate value.
  void Add(int view, const core::Image& truth, const core::Image& estimate);

  // Over every view added with theta <= theta_max_deg (all by default).
  BtfErrorFigures Overall(double theta_max_deg = 90.0) const;
  struct Band {
    double theta_min_deg = 0.0;
    double theta_max_deg = 0.0;
    BtfErrorFigures figures;
  };
  // The non-empty bands, in order.
  std::vector<Band> ByPolarAngle() const;
  double peak() const { return peak_; }

 private:
  struct Sums {
    double error = 0.0;  // sum of squared differences
    double truth = 0.0;  // sum of squared true values
    long long values = 0;
  };
  BtfErrorFigures Figures(const Sums& s) const;

  core::SamplingSet views_;
  double band_deg_;
  std::vector<Sums> per_view_;
  double peak_ = 0.0;
};

// `mesocap eval btf --json`: {"overall": {"psnr_db", "relative_rms"},
// "by_polar_angle": [{"theta_min_deg", "theta_max_deg", "psnr_db",
// "relative_rms"}, ...], "rank": K or null (a full estimate), "peak"}. An
// infinite PSNR (exact estimate) is written as null.
nlohmann::json ToJson(const BtfErrorAccumulator& errors, std::optional<int> rank);

}  // namespace mesocap::btf
