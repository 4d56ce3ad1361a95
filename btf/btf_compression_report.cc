#include "btf/btf_compression_report.h"

#include <sstream>

#include "btf/btf_compression.h"

namespace mesocap::btf {
namespace compression {

std::string Percent(double relative) {
  std::ostringstream s;
  s.precision(3);
  s << relative * 100.0 << "%";
  return s.str();
}

std::string RepresentationName(core::BtfFactorLayout layout, core::BtfFactorColor color, int clusters) {
  return std::string(ToString(layout)) +
         (layout == core::BtfFactorLayout::kClustered ? "(" + std::to_string(clusters) + ")" : std::string()) + "/" +
         ToString(color);
}

std::string Bytes(long long bytes) {
  std::ostringstream s;
  s.precision(3);
  if (bytes < (1LL << 20)) {
    s << bytes / 1024.0 << " KiB";
  } else if (bytes < (1LL << 30)) {
    s << bytes / double(1LL << 20) << " MiB";
  } else {
    s << bytes / double(1LL << 30) << " GiB";
  }
  return s.str();
}

}  // namespace compression

nlohmann::json ToJson(const BtfCompressionReport& report, const core::FactoredBtf& factored) {
  const char* names[2][3] = {{"r", "g", "b"}, {"y", "cb", "cr"}};
  nlohmann::json spectrum = nlohmann::json::object();
  for (int ch = 0; ch < 3; ++ch) {
    const Eigen::VectorXd& s = report.singular_values[ch];
    spectrum[names[factored.color == core::BtfFactorColor::kYCbCr][ch]] =
        std::vector<double>(s.data(), s.data() + s.size());
  }
  nlohmann::json candidates = nlohmann::json::array();
  for (const BtfRepresentationCandidate& c : report.candidates) {
    nlohmann::json one = {{"layout", ToString(c.layout)},
                          {"color", ToString(c.color)},
                          {"rank", c.rank},
                          {"factor_bytes", c.factor_bytes},
                          {"relative_rms", c.relative_rms_error},
                          {"error_from", c.measured                              ? "measured"
                                         : c.color == core::BtfFactorColor::kRgb ? "spectrum"
                                                                                 : "spectrum in Y, Cb, Cr"},
                          {"meets_budget", c.meets_budget}};
    if (c.layout == core::BtfFactorLayout::kClustered) one["clusters"] = c.clusters;
    if (!c.note.empty()) one["note"] = c.note;
    candidates.push_back(std::move(one));
  }
  nlohmann::json out = {{"layout", ToString(factored.layout)},
                        {"color", ToString(factored.color)},
                        {"rank", report.rank},
                        {"reason", report.reason},
                        {"measured_relative_rms", report.measured_relative_rms_error},
                        {"factor_bytes", report.factor_bytes},
                        {"relative_rms_by_rank", report.relative_rms_error},
                        {"max_rank", report.max_rank},
                        {"matrix_size", {report.matrix_rows, report.matrix_columns}},
                        {"svd", report.svd},
                        {"singular_values", spectrum},
                        {"seconds", report.seconds}};
  if (factored.layout == core::BtfFactorLayout::kClustered) out["clusters"] = factored.cluster_count;
  if (!report.candidates.empty()) {
    out["representation_reason"] = report.representation_reason;
    out["candidates"] = std::move(candidates);
  }
  return out;
}

}  // namespace mesocap::btf
