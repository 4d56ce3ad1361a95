#include "mdf/mdf_evaluation.h"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>

#include "core/angles.h"
#include "core/error.h"

namespace mesocap::mdf {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double Quantile(std::vector<double>& values, double q) {
  if (values.empty()) return kNaN;
  const auto k = static_cast<std::size_t>(std::ceil(q * values.size())) - (q > 0 ? 1 : 0);
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

void CheckComparable(const core::Mdf& truth, const core::Mdf& estimate) {
  if (truth.width != estimate.width || truth.height != estimate.height || truth.view_count() != estimate.view_count()) {
    throw core::Error("eval mdf: truth is " + std::to_string(truth.width) + "x" + std::to_string(truth.height) + " x " +
                      std::to_string(truth.view_count()) + " views, estimate " + std::to_string(estimate.width) + "x" +
                      std::to_string(estimate.height) + " x " + std::to_string(estimate.view_count()));
  }
  for (int v = 0; v < truth.view_count(); ++v) {
    if (truth.views.direction(v).dot(estimate.views.direction(v)) < std::cos(1e-6)) {
      throw core::Error("eval mdf: view " + std::to_string(v) + " differs between truth and estimate");
    }
  }
}

}  // namespace

MdfErrorRow EvaluateMdfViews(const core::Mdf& truth, const core::Mdf& estimate, double texel_mm,
                             const MdfEvaluationScope& scope) {
  CheckComparable(truth, estimate);
  const double theta_min_deg = scope.theta_min_deg, theta_max_deg = scope.theta_max_deg;
  const double half_x = 0.5 * texel_mm * truth.width, half_y = 0.5 * texel_mm * truth.height;
  MdfErrorRow row;
  row.theta_min_deg = theta_min_deg;
  row.theta_max_deg = theta_max_deg;
  std::vector<double> errors;
  long long covered = 0, false_no_hit = 0, false_hit = 0, measured_no_hit = 0;
  for (int v = 0; v < truth.view_count(); ++v) {
    const double theta = core::DegreesFromRadians(truth.views.angles(v).theta);
    if (theta < theta_min_deg - 1e-9 || theta > theta_max_deg + 1e-9) continue;
    for (int j = 0; j < truth.height; ++j) {
      for (int i = 0; i < truth.width; ++i) {
        const float t = truth.at(i, j, v), e = estimate.at(i, j, v);
        if (core::IsUnknown(t)) continue;
        if (scope.inside_sample_only && std::isfinite(t)) {
          const Eigen::Vector3d hit =
              Eigen::Vector3d(-half_x + (i + 0.5) * texel_mm, -half_y + (j + 0.5) * texel_mm, 0) -
              static_cast<double>(t) * truth.views.direction(v);
          if (std::abs(hit.x()) > half_x || std::abs(hit.y()) > half_y) continue;
        }
        if (core::IsNoHit(t)) {
          ++row.true_no_hits;
          if (std::isfinite(e)) ++false_hit;
          if (core::IsNoHit(e)) ++measured_no_hit;
          continue;
        }
        ++row.true_hits;
        if (core::IsNoHit(e)) ++false_no_hit;
        if (std::isfinite(e)) {
          ++covered;
          errors.push_back(std::abs(static_cast<double>(e) - t));
        }
      }
    }
  }
  row.compared = static_cast<long long>(errors.size());
  row.median_mm = Quantile(errors, 0.5);
  row.p95_mm = Quantile(errors, 0.95);
  row.median_texels = row.median_mm / texel_mm;
  row.p95_texels = row.p95_mm / texel_mm;
  row.coverage = row.true_hits ? static_cast<double>(covered) / row.true_hits : kNaN;
  row.false_no_hit_rate = row.true_hits ? static_cast<double>(false_no_hit) / row.true_hits : kNaN;
  row.false_hit_rate = row.true_no_hits ? static_cast<double>(false_hit) / row.true_no_hits : kNaN;
  row.no_hit_coverage = row.true_no_hits ? static_cast<double>(measured_no_hit) / row.true_no_hits : kNaN;
  return row;
}

MdfErrorTable EvaluateMdf(const core::Mdf& truth, const core::Mdf& estimate, double texel_mm, bool inside_sample_only) {
  if (!(texel_mm > 0)) throw core::Error("eval mdf: texel width must be positive");
  MdfErrorTable table;
  table.overall = EvaluateMdfViews(truth, estimate, texel_mm, {0, 90, inside_sample_only});
  for (int b = 0; b < 6; ++b) {
    // Half-open buckets but the last, so each view counts once.
    const double lo = 15.0 * b, hi = b == 5 ? 90.0 : 15.0 * (b + 1) - 1e-7;
    MdfErrorRow row = EvaluateMdfViews(truth, estimate, texel_mm, {lo, hi, inside_sample_only});
    row.theta_max_deg = 15.0 * (b + 1);
    table.by_polar_angle.push_back(row);
  }
  return table;
}

namespace {

nlohmann::json Number(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json RowJson(const MdfErrorRow& r, bool with_range) {
  nlohmann::json j = {{"median_mm", Number(r.median_mm)},
                      {"p95_mm", Number(r.p95_mm)},
                      {"median_texels", Number(r.median_texels)},
                      {"p95_texels", Number(r.p95_texels)},
                      {"coverage", Number(r.coverage)},
                      {"false_no_hit_rate", Number(r.false_no_hit_rate)},
                      {"false_hit_rate", Number(r.false_hit_rate)},
                      {"no_hit_coverage", Number(r.no_hit_coverage)},
                      {"true_hits", r.true_hits},
                      {"true_no_hits", r.true_no_hits},
                      {"compared", r.compared}};
  if (with_range) {
    j["theta_min_deg"] = r.theta_min_deg;
    j["theta_max_deg"] = r.theta_max_deg;
  }
  return j;
}

}  // namespace

nlohmann::json ToJson(const MdfErrorTable& table) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : table.by_polar_angle) rows.push_back(RowJson(r, true));
  return {{"overall", RowJson(table.overall, false)}, {"by_polar_angle", rows}};
}

std::string FormatMdfErrorTable(const MdfErrorTable& table) {
  std::string out =
      "theta (deg)   median mm   p95 mm  median tx   p95 tx  coverage  false no-hit  false hit  no-hit cov   "
      "compared\n";
  // A figure with nothing to count (NaN) prints as "-"; the notes below say why.
  auto cell = [](double value, int width, int precision) {
    char buffer[64];
    if (std::isnan(value)) {
      std::snprintf(buffer, sizeof buffer, " %*s", width, "-");
    } else {
      std::snprintf(buffer, sizeof buffer, " %*.*f", width, precision, value);
    }
    return std::string(buffer);
  };
  bool any_no_hit = false;
  auto line = [&](const std::string& label, const MdfErrorRow& r) {
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, "%-12s", label.c_str());
    out += buffer + cell(r.median_mm, 10, 4) + cell(r.p95_mm, 8, 4) + cell(r.median_texels, 10, 3) +
           cell(r.p95_texels, 8, 3) + cell(r.coverage, 9, 4) + cell(r.false_no_hit_rate, 13, 4) +
           cell(r.false_hit_rate, 10, 4) + cell(r.no_hit_coverage, 11, 4);
    std::snprintf(buffer, sizeof buffer, " %10lld\n", r.compared);
    out += buffer;
    any_no_hit = any_no_hit || r.true_no_hits > 0;
  };
  // Bands where the sampling set has no view hold no data: left out, named.
  std::string empty_bands;
  for (const auto& r : table.by_polar_angle) {
    const std::string band =
        std::to_string(static_cast<int>(r.theta_min_deg)) + "-" + std::to_string(static_cast<int>(r.theta_max_deg));
    if (r.true_hits == 0 && r.true_no_hits == 0) {
      empty_bands += (empty_bands.empty() ? "" : ", ") + band;
      continue;
    }
    line(band, r);
  }
  line("overall", table.overall);
  if (!empty_bands.empty()) out += "left out: polar bands " + empty_bands + " deg (no view direction there)\n";
  if (!any_no_hit) out += "false hit and no-hit cov: - (the truth has no \"no hit\": no ray leaves the slab)\n";
  return out;
}

}  // namespace mesocap::mdf
