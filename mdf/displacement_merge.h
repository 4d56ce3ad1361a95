// Merging the displacement images of one view across laser locations (MDF
// paper Sec. 3.2, "Merging displacement images"):
//   D_v(x, y) = sum_i w_i D_v,li(x, y) / sum_i w_i   over D_v,li != unknown,
// w_i the volume of the tetrahedron of the laser source, the camera and two
// points of the laser line through the turntable centre (after the shadow
// scanning error analysis the paper cites: the volume vanishes as the camera
// approaches the laser plane, where triangulation degrades).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/error.h"
#include "core/plane.h"
#include "mdf/displacement_image.h"

namespace mesocap::mdf {

// Volume of the tetrahedron (source, camera, line_a, line_b), mm^3.
double TetrahedronVolume(const Eigen::Vector3d& source, const Eigen::Vector3d& camera, const Eigen::Vector3d& line_a,
                         const Eigen::Vector3d& line_b);

// The paper's weight of a scan: the tetrahedron with the two points of the
// plane's trace on z = 0, shifted to pass through the turntable centre
// (origin), at +-half_length_mm from it. 0 for an invalid or horizontal plane.
double ScanWeight(const Eigen::Vector3d& source, const Eigen::Vector3d& camera, const core::Plane& plane,
                  double half_length_mm);

struct MergeOptions {
  // Values farther than this (texel widths) from the per-texel weighted
  // median are outliers (a scan that saw a ghost or a hidden surface) and
  // left out of the mean.
  double outlier_texels = 1.5;

  core::CheckResult Check() const;
};

// The merged image and a per-texel confidence in [0, 1]: the share of the
// view's total scan weight whose scans agree on the texel's value (0 where
// unknown). "No hit" (+infinity) takes part in the weighted median like a
// distance beyond all others: a texel is no hit when scans holding more than
// half the weight that measured it saw its ray reach the backing (ties go
// to the distance).
struct MergedDisplacement {
  DisplacementImage image;
  std::vector<float> confidence;
};

// images and weights pair up (weights > 0; all images the same size).
// Throws Error otherwise.
MergedDisplacement MergeDisplacementImages(const std::vector<DisplacementImage>& images,
                                           const std::vector<double>& weights, double texel_mm,
                                           const MergeOptions& options);

}  // namespace mesocap::mdf
