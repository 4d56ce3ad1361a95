#include "calibration/texel_grid.h"

#include <cmath>

#include "core/image.h"

namespace mesocap::calibration {

core::CheckResult TexelGrid::Check() const {
  if (auto problem = core::CheckImageSize(width, height, "texture size"); !problem.empty()) return problem;
  if (!(sample_size_mm > 0 && std::isfinite(sample_size_mm))) return "sample_size_mm must be positive";
  return {};
}

}  // namespace mesocap::calibration
