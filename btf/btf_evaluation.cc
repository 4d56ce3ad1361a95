#include "btf/btf_evaluation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "core/angles.h"
#include "core/error.h"

namespace mesocap::btf {
namespace {

nlohmann::json Number(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

double ThetaDeg(const core::SamplingSet& set, int i) { return core::DegreesFromRadians(set.angles(i).theta); }

}  // namespace

BtfErrorAccumulator::BtfErrorAccumulator(core::SamplingSet views, double band_deg)
    : views_(std::move(views)), band_deg_(band_deg), per_view_(views_.size()) {
  if (!(band_deg > 0.0 && band_deg <= 90.0)) throw core::Error("BTF evaluation: band width must be in (0, 90] degrees");
}

void BtfErrorAccumulator::Add(int view, const core::Image& truth, const core::Image& estimate) {
  if (view < 0 || view >= views_.size())
    throw core::Error("BTF evaluation: view " + std::to_string(view) + " out of range");
  if (truth.width() != estimate.width() || truth.height() != estimate.height() ||
      truth.channels() != estimate.channels()) {
    throw core::Error("BTF evaluation: view " + std::to_string(view) + " images differ in size");
  }
  Sums& s = per_view_[view];
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const double t = truth.data()[i], e = estimate.data()[i];
    if (!std::isfinite(e))
      throw core::Error("BTF evaluation: the estimate's view " + std::to_string(view) + " is not finite");
    s.error += (t - e) * (t - e);
    s.truth += t * t;
    peak_ = std::max(peak_, std::abs(t));
  }
  s.values += static_cast<long long>(truth.size());
}

BtfErrorFigures BtfErrorAccumulator::Figures(const Sums& s) const {
  BtfErrorFigures f;
  f.values = s.values;
  f.relative_rms = s.truth > 0.0 ? std::sqrt(s.error / s.truth)
                                 : (s.error > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
  const double mse = s.values > 0 ? s.error / s.values : 0.0;
  f.psnr_db = mse > 0.0 ? 10.0 * std::log10(peak_ * peak_ / mse) : std::numeric_limits<double>::infinity();
  return f;
}

BtfErrorFigures BtfErrorAccumulator::Overall(double theta_max_deg) const {
  Sums total;
  for (int v = 0; v < views_.size(); ++v) {
    if (ThetaDeg(views_, v) > theta_max_deg) continue;
    total.error += per_view_[v].error;
    total.truth += per_view_[v].truth;
    total.values += per_view_[v].values;
  }
  return Figures(total);
}

std::vector<BtfErrorAccumulator::Band> BtfErrorAccumulator::ByPolarAngle() const {
  const int bands = static_cast<int>(std::ceil(90.0 / band_deg_ - 1e-9));
  std::vector<Sums> sums(bands);
  for (int v = 0; v < views_.size(); ++v) {
    const int b = std::min(bands - 1, static_cast<int>(ThetaDeg(views_, v) / band_deg_));
    sums[b].error += per_view_[v].error;
    sums[b].truth += per_view_[v].truth;
    sums[b].values += per_view_[v].values;
  }
  std::vector<Band> out;
  for (int b = 0; b < bands; ++b) {
    if (sums[b].values == 0) continue;
    out.push_back({b * band_deg_, std::min(90.0, (b + 1) * band_deg_), Figures(sums[b])});
  }
  return out;
}

nlohmann::json ToJson(const BtfErrorAccumulator& errors, std::optional<int> rank) {
  const BtfErrorFigures overall = errors.Overall();
  nlohmann::json bands = nlohmann::json::array();
  for (const auto& b : errors.ByPolarAngle()) {
    bands.push_back({{"theta_min_deg", b.theta_min_deg},
                     {"theta_max_deg", b.theta_max_deg},
                     {"psnr_db", Number(b.figures.psnr_db)},
                     {"relative_rms", Number(b.figures.relative_rms)}});
  }
  return {{"overall", {{"psnr_db", Number(overall.psnr_db)}, {"relative_rms", Number(overall.relative_rms)}}},
          {"by_polar_angle", bands},
          {"rank", rank ? nlohmann::json(*rank) : nlohmann::json(nullptr)},
          {"peak", errors.peak()}};
}

}  // namespace mesocap::btf
