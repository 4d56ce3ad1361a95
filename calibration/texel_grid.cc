#include "calibration/texel_grid.h"

#include <cmath>

#include "formats/material_package.h"

namespace mesocap::calibration {

core::CheckResult TexelGrid::Check() const {
  if (width < 1 || height < 1 || width > formats::kMaxTextureSize || height > formats::kMaxTextureSize) {
    return "texture size must be in 1.." + std::to_string(formats::kMaxTextureSize);
  }
  if (!(sample_size_mm > 0 && std::isfinite(sample_size_mm))) return "sample_size_mm must be positive";
  return {};
}

}  // namespace mesocap::calibration
