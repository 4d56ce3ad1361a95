// The texture's texels on the sample (docs/FORMATS.md "Texture grid"): a
// W x H grid covers the clipped square sample of side S centred on the
// sample-frame origin, texture coordinates (x, y) in [0,1)^2 with x along the
// sample's +X. Texel (i, j) is centred on the reference-plane point
// (-S/2 + (i + 0.5) S / W, -S/2 + (j + 0.5) S / H, 0). The BTF is rectified
// onto these centres (MDF paper Sec. 3.1), the displacement images are
// resampled to them (Sec. 3.2) and the ground truth is cast from them.
#pragma once

#include <Eigen/Core>

#include "core/error.h"

namespace mesocap::calibration {

struct TexelGrid {
  int width = 64;   // texels along +X
  int height = 64;  // texels along +Y
  double sample_size_mm = 20.0;

  // A texel's extent along +X (S / W) and along +Y (S / H).
  double texel_width_mm() const { return sample_size_mm / width; }
  double texel_height_mm() const { return sample_size_mm / height; }

  // The reference-plane point at the centre of texel (i, j), sample frame.
  Eigen::Vector3d TexelCentre(int i, int j) const {
    const double s = sample_size_mm;
    return {-s / 2 + (i + 0.5) * s / width, -s / 2 + (j + 0.5) * s / height, 0.0};
  }

  // The continuous texel coordinates (u, v) of a sample-frame point (x, y):
  // texel (i, j) is centred on (u, v) = (i, j), and the square covers
  // [-0.5, W - 0.5) x [-0.5, H - 0.5).
  Eigen::Vector2d TexelCoordinates(double x_mm, double y_mm) const {
    return {(x_mm + 0.5 * sample_size_mm) / texel_width_mm() - 0.5,
            (y_mm + 0.5 * sample_size_mm) / texel_height_mm() - 0.5};
  }

  core::CheckResult Check() const;
};

}  // namespace mesocap::calibration
