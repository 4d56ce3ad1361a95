// Resampling of captured BTF directions onto a session's direction sets, for
// a rig whose directions are off the set's grid. A capture i was taken from a
// direction d_i(x) that depends on the texel x (a lamp at 450 mm or a camera
// at 300 mm is seen ~1-2 degrees differently across a 12 mm sample) and, on a
// real or off-grid rig, is not a direction of the target set.
//
// The captures' directions at the sample centre, d_i(0), are grouped into
// rings (thetas within ring_tolerance share their mean: a calibrated,
// slightly tilted turntable makes them differ by more than SamplingSet's
// 1e-9) giving nominal directions n_i and a SamplingSet over them. The value
// at a target direction t is SamplingSet::Interpolate's blend of the captures
// at a query moved by the captures' offsets o_i = d_i - n_i:
//   q = normalize(t - sum_b w_b(t) o_b),   value = sum_b w_b(q) T_b,
// so that interpolating on the nominal set at q stands for interpolating on
// the actual directions at t, to first order in the offsets (the offsets are
// a few degrees, the rings tens of degrees apart).
//
// Conditioning (SamplingSet::Interpolate): linear in phi within the two
// captured rings bracketing theta and linear in theta between them. Where
// the captures are sparse (the tiny rig: views 30 degrees apart in theta, 90
// in phi) a linear blend cannot follow parallax and shadow edges, and moving
// weight by o / spacing mixes in a capture seen from tens of degrees away;
// targets beyond the last captured ring (grazing) or above the first (near
// the pole without a pole capture) are clamped to that ring: extrapolated,
// constant in theta, and counted as such by the assembly.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/sampling_set.h"

namespace mesocap::btf {

struct CapturedDirections {
  core::SamplingSet nominal;            // capture i at index i
  std::vector<Eigen::Vector3d> offset;  // d_i(0) - n_i, sample frame
  double first_ring_theta = 0.0;        // radians, the captured range
  double last_ring_theta = 0.0;
};

// Throws Error (naming `what`) for an empty list or two captures whose
// nominal directions coincide.
CapturedDirections MakeCapturedDirections(const std::string& what, const std::vector<Eigen::Vector3d>& centre,
                                          double ring_tolerance_rad);

// The blend of captures for target t; offset(i) is capture i's actual
// direction minus its nominal one (at the texel being resampled).
template <typename Offset>
core::SamplingSet::Blend ResampleBlend(const core::SamplingSet& nominal, const Eigen::Vector3d& target,
                                       const Offset& offset) {
  const core::SamplingSet::Blend first = nominal.Interpolate(target);
  Eigen::Vector3d shift = Eigen::Vector3d::Zero();
  for (int b = 0; b < first.count; ++b) shift += first.weight[b] * offset(first.index[b]);
  if (shift.squaredNorm() == 0.0) return first;
  return nominal.Interpolate((target - shift).normalized());
}

}  // namespace mesocap::btf
