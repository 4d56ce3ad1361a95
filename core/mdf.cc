#include "core/mdf.h"

#include <algorithm>
#include <limits>
#include <string>

#include "core/error.h"

namespace mesocap::core {

Mdf MakeMdf(int width, int height, SamplingSet views) {
  if (views.size() < 1) throw Error("an MDF needs at least one view direction");
  if (static_cast<long long>(height) * views.size() > std::numeric_limits<int>::max()) {
    throw Error("MDF of " + std::to_string(height) + " rows x " + std::to_string(views.size()) +
                " views is too tall for one image");
  }
  Mdf mdf;
  mdf.width = width;
  mdf.height = height;
  mdf.distance_mm = Image(width, height * views.size(), 1, MdfUnknown());
  mdf.views = std::move(views);
  return mdf;
}

double MdfQuantizationScale(const Mdf& mdf, double d_max_mm) {
  if (!(std::isfinite(d_max_mm) && d_max_mm > 0)) {
    throw Error("MDF quantization: d_max must be a positive distance, got " + std::to_string(d_max_mm));
  }
  float largest = 0.0f;
  const float* d = mdf.distance_mm.data();
  for (std::size_t i = 0; i < mdf.distance_mm.size(); ++i) {
    if (std::isfinite(d[i])) largest = std::max(largest, d[i]);
  }
  return (largest > 0 ? static_cast<double>(largest) : d_max_mm) / QuantizedMdf::kMaxDistanceCode;
}

QuantizedMdf QuantizeMdf(const Mdf& mdf, double d_max_mm) {
  QuantizedMdf q;
  q.width = mdf.width;
  q.height = mdf.height;
  q.views = mdf.views;
  q.scale_mm = MdfQuantizationScale(mdf, d_max_mm);
  q.codes.resize(mdf.distance_mm.size());
  const float* d = mdf.distance_mm.data();
  for (std::size_t i = 0; i < q.codes.size(); ++i) {
    if (!IsValidMdfValue(d[i])) {
      throw Error("MDF quantization: value " + std::to_string(d[i]) + " at index " + std::to_string(i) +
                  " is neither a distance >= 0, no hit (+inf) nor unknown (NaN)");
    }
    if (IsUnknown(d[i])) {
      q.codes[i] = QuantizedMdf::kUnknownCode;
    } else if (IsNoHit(d[i])) {
      q.codes[i] = QuantizedMdf::kNoHitCode;
    } else {
      // Rounding (not truncation) is what bounds the error by scale/2.
      const double code = std::round(static_cast<double>(d[i]) / q.scale_mm);
      q.codes[i] = static_cast<std::uint8_t>(std::clamp(code, 0.0, double{QuantizedMdf::kMaxDistanceCode}));
    }
  }
  return q;
}

Mdf DequantizeMdf(const QuantizedMdf& q) {
  if (!(std::isfinite(q.scale_mm) && q.scale_mm > 0)) {
    throw Error("8-bit MDF: scale must be a positive distance, got " + std::to_string(q.scale_mm));
  }
  Mdf mdf = MakeMdf(q.width, q.height, q.views);
  if (q.codes.size() != mdf.distance_mm.size()) {
    throw Error("8-bit MDF: " + std::to_string(q.codes.size()) + " codes for " +
                std::to_string(mdf.distance_mm.size()) + " values");
  }
  float* d = mdf.distance_mm.data();
  for (std::size_t i = 0; i < q.codes.size(); ++i) {
    const std::uint8_t c = q.codes[i];
    if (c == QuantizedMdf::kUnknownCode) {
      d[i] = MdfUnknown();
    } else if (c == QuantizedMdf::kNoHitCode) {
      d[i] = MdfNoHit();
    } else {
      d[i] = static_cast<float>(c * q.scale_mm);
    }
  }
  return mdf;
}

}  // namespace mesocap::core
