// The ambient term La(x, y, view) of Wang et al. 2005 Sec. 4.2: what a point
// in macroscale shadow shows under uniform sky light, by quadrature over the
// BTF's light directions with the sampling set's solid-angle weights:
//   La(x, y, v) = sum_l T(x, y, v, l) cos(theta_l) w_l.
// The cosine is there because mesocap's T is reflectance normalised by the
// light's cosine (sim/ground_truth.h: a flat Lambertian sample has
// T = albedo / pi), so T cos(theta_l) is the outgoing radiance per unit
// incident radiance; a flat Lambertian sample then has La = albedo (up to the
// quadrature error of integrating cos theta on the light set: ~0.5% on
// grid24x12, a few percent on sparse rig sets).
#pragma once

#include "core/btf.h"
#include "core/image.h"
#include "formats/material_package.h"

namespace mesocap::btf {

// An all-zero ambient term of the BTF's size and view set.
formats::AmbientTerm MakeAmbientTerm(int width, int height, const core::SamplingSet& views);

// Adds view `view`'s contribution from its full-BTF view image (3 channels,
// W x H * Nlight), so a large BTF can be integrated view by view as it is
// read or assembled. Throws Error on a size mismatch or a view out of range.
void AddAmbientView(const core::Image& btf_view, const core::SamplingSet& lights, int view,
                    formats::AmbientTerm* ambient);

// La of a whole BTF in memory.
formats::AmbientTerm ComputeAmbientTerm(const core::FullBtf& btf);

}  // namespace mesocap::btf
