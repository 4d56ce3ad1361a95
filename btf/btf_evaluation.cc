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

// The figures of each kind of pair (see ToJson), in the JSON's order.
struct PairKindErrors {
  int pairs = 0;
  BtfErrorFigures errors;
};
std::vector<std::pair<std::string, PairKindErrors>> PairKindFigures(const BtfErrorAccumulator& errors,
                                                                    const BtfPairRecord& pairs) {
  const core::SamplingSet& views = errors.views();
  const core::SamplingSet& lights = errors.lights();
  const auto within_60 = [&](int v, int l) {
    return ThetaDeg(views, v) <= 60.0 + 1e-9 && ThetaDeg(lights, l) <= 60.0 + 1e-9;
  };
  const std::vector<std::pair<std::string, std::function<bool(int, int)>>> kinds = {
      {"captured", [&](int v, int l) { return pairs.resolved(v) && pairs.captured[v][l]; }},
      {"interpolated", [&](int v, int l) { return pairs.resolved(v) && !pairs.captured[v][l]; }},
      {"unresolved", [&](int v, int) { return !pairs.resolved(v); }},
      {"captured_within_60deg",
       [&](int v, int l) { return pairs.resolved(v) && pairs.captured[v][l] && within_60(v, l); }}};
  std::vector<std::pair<std::string, PairKindErrors>> out;
  for (const auto& [kind, include] : kinds) {
    PairKindErrors k;
    k.errors = errors.Over(include);
    for (int v = 0; v < views.size(); ++v)
      for (int l = 0; l < lights.size(); ++l) k.pairs += include(v, l);
    out.emplace_back(kind, k);
  }
  return out;
}

}  // namespace

void AddPairRecord(const BtfPairRecord& record, nlohmann::json* object) {
  (*object)["captured"] = record.captured;
  (*object)["pixels_per_texel"] = record.pixels_per_texel;
}

std::optional<BtfPairRecord> ReadPairRecord(const nlohmann::json& object, const std::filesystem::path& file, int views,
                                            int lights) {
  if (!object.is_object() || !object.contains("captured")) return std::nullopt;
  const auto bad = [&](const std::string& field, const std::string& expected) {
    throw core::FormatError(file, "btf_assembly." + field, "expected " + expected);
  };
  const nlohmann::json& captured = object["captured"];
  if (!captured.is_array() || static_cast<int>(captured.size()) != views) {
    bad("captured", "an array of " + std::to_string(views) + " views");
  }
  const nlohmann::json* pixels = object.contains("pixels_per_texel") ? &object["pixels_per_texel"] : nullptr;
  if (pixels == nullptr || !pixels->is_array() || static_cast<int>(pixels->size()) != views) {
    bad("pixels_per_texel", "an array of " + std::to_string(views) + " numbers");
  }
  BtfPairRecord record;
  for (int v = 0; v < views; ++v) {
    const nlohmann::json& row = captured[v];
    if (!row.is_array() || static_cast<int>(row.size()) != lights) {
      bad("captured[" + std::to_string(v) + "]", "an array of " + std::to_string(lights) + " booleans");
    }
    std::vector<bool>& out = record.captured.emplace_back();
    for (const nlohmann::json& c : row) {
      if (!c.is_boolean()) bad("captured[" + std::to_string(v) + "]", "booleans");
      out.push_back(c.get<bool>());
    }
    const nlohmann::json& p = (*pixels)[v];
    if (!p.is_number() || !(p.get<double>() >= 0.0)) {
      bad("pixels_per_texel[" + std::to_string(v) + "]", "a number >= 0");
    }
    record.pixels_per_texel.push_back(p.get<double>());
  }
  return record;
}

BtfErrorAccumulator::BtfErrorAccumulator(core::SamplingSet views, core::SamplingSet lights, double band_deg)
    : views_(std::move(views)),
      lights_(std::move(lights)),
      band_deg_(band_deg),
      per_pair_(static_cast<std::size_t>(views_.size()) * lights_.size()) {
  if (lights_.size() < 1) throw core::Error("BTF evaluation: a view image needs at least one light");
  if (!(band_deg > 0.0 && band_deg <= 90.0)) throw core::Error("BTF evaluation: band width must be in (0, 90] degrees");
}

void BtfErrorAccumulator::Add(int view, const core::Image& truth, const core::Image& estimate) {
  if (view < 0 || view >= views_.size())
    throw core::Error("BTF evaluation: view " + std::to_string(view) + " out of range");
  if (truth.width() != estimate.width() || truth.height() != estimate.height() ||
      truth.channels() != estimate.channels()) {
    throw core::Error("BTF evaluation: view " + std::to_string(view) + " images differ in size");
  }
  const int lights = lights_.size();
  if (truth.height() % lights != 0) {
    throw core::Error("BTF evaluation: view " + std::to_string(view) + " is not " + std::to_string(lights) +
                      " light slices of equal height");
  }
  // Light l is rows [l * h, (l + 1) * h): a contiguous run of values.
  const std::size_t per_light = truth.size() / lights;
  for (int l = 0; l < lights; ++l) {
    Sums& s = per_pair_[static_cast<std::size_t>(view) * lights + l];
    for (std::size_t i = l * per_light; i < (l + 1) * per_light; ++i) {
      const double t = truth.data()[i], e = estimate.data()[i];
      if (!std::isfinite(e))
        throw core::Error("BTF evaluation: the estimate's view " + std::to_string(view) + " is not finite");
      s.error += (t - e) * (t - e);
      s.truth += t * t;
      peak_ = std::max(peak_, std::abs(t));
    }
    s.values += static_cast<long long>(per_light);
  }
}

BtfErrorFigures BtfErrorAccumulator::Figures(const Sums& s) const {
  BtfErrorFigures f;
  f.values = s.values;
  f.relative_rms =
      s.truth > 0.0 ? std::sqrt(s.error / s.truth) : (s.error > 0.0 ? std::numeric_limits<double>::infinity() : 0.0);
  const double mse = s.values > 0 ? s.error / s.values : 0.0;
  f.psnr_db = mse > 0.0 ? 10.0 * std::log10(peak_ * peak_ / mse) : std::numeric_limits<double>::infinity();
  return f;
}

BtfErrorFigures BtfErrorAccumulator::Over(const std::function<bool(int view, int light)>& include) const {
  Sums total;
  for (int v = 0; v < views_.size(); ++v) {
    for (int l = 0; l < lights_.size(); ++l) {
      if (!include(v, l)) continue;
      const Sums& s = per_pair_[static_cast<std::size_t>(v) * lights_.size() + l];
      total.error += s.error;
      total.truth += s.truth;
      total.values += s.values;
    }
  }
  return Figures(total);
}

BtfErrorFigures BtfErrorAccumulator::Overall(double theta_max_deg) const {
  return Over([&](int v, int) { return ThetaDeg(views_, v) <= theta_max_deg; });
}

std::vector<BtfErrorAccumulator::Band> BtfErrorAccumulator::ByPolarAngle() const {
  const int bands = static_cast<int>(std::ceil(90.0 / band_deg_ - 1e-9));
  const auto band_of = [&](int v) { return std::min(bands - 1, static_cast<int>(ThetaDeg(views_, v) / band_deg_)); };
  std::vector<Band> out;
  for (int b = 0; b < bands; ++b) {
    const BtfErrorFigures figures = Over([&](int v, int) { return band_of(v) == b; });
    if (figures.values == 0) continue;
    out.push_back({b * band_deg_, std::min(90.0, (b + 1) * band_deg_), figures});
  }
  return out;
}

nlohmann::json ToJson(const BtfErrorAccumulator& errors, std::optional<int> rank,
                      const std::optional<BtfPairRecord>& pairs) {
  const BtfErrorFigures overall = errors.Overall();
  nlohmann::json bands = nlohmann::json::array();
  for (const auto& b : errors.ByPolarAngle()) {
    bands.push_back({{"theta_min_deg", b.theta_min_deg},
                     {"theta_max_deg", b.theta_max_deg},
                     {"psnr_db", Number(b.figures.psnr_db)},
                     {"relative_rms", Number(b.figures.relative_rms)}});
  }
  nlohmann::json out = {
      {"overall", {{"psnr_db", Number(overall.psnr_db)}, {"relative_rms", Number(overall.relative_rms)}}},
      {"by_polar_angle", bands},
      {"rank", rank ? nlohmann::json(*rank) : nlohmann::json(nullptr)},
      {"peak", errors.peak()}};
  for (const char* kind : {"captured", "interpolated", "unresolved", "captured_within_60deg"}) out[kind] = nullptr;
  if (!pairs) return out;
  for (const auto& [kind, figures] : PairKindFigures(errors, *pairs)) {
    out[kind] = {{"pairs", figures.pairs},
                 {"psnr_db", Number(figures.errors.psnr_db)},
                 {"relative_rms", Number(figures.errors.relative_rms)}};
  }
  int unresolved_views = 0;
  for (int v = 0; v < errors.views().size(); ++v) unresolved_views += !pairs->resolved(v);
  out["unresolved"]["views"] = unresolved_views;
  return out;
}

}  // namespace mesocap::btf
