// Exact ground truth of a mesostructure scene, computed directly in texture
// space (no cameras, no noise): the MDF by ray casting from the reference
// plane, the BTF under distant lights with mesoscale shadows, and the ambient
// term. Everything a measured material is compared against.
//
// The rays start at the texel centres of the texel grid
// (calibration/texel_grid.h): column i along +X, row j along +Y.
#pragma once

#include <Eigen/Core>
#include <filesystem>

#include "calibration/texel_grid.h"
#include "core/btf.h"
#include "core/error.h"
#include "core/image.h"
#include "core/mdf.h"
#include "core/progress.h"
#include "core/sampling_set.h"
#include "formats/calibration.h"
#include "formats/material_package.h"
#include "sim/mesostructure_scene.h"

namespace mesocap::sim {

struct GroundTruthOptions {
  calibration::TexelGrid texels;  // the texels the truth is computed at
  core::SamplingSet views = core::SamplingSet::Named("paper12x8");
  core::SamplingSet lights = core::SamplingSet::Named("paper12x8");
  // The BTF (and so the ambient term) of a texel is the mean over n x n
  // stratified points of its area, as a camera pixel and the rectifier's
  // prefilter average over their footprints; 1 samples the texel centre.
  // The MDF is a distance at the texel centre (Sec. 3.2) and stays one.
  int samples_per_side = 1;

  core::CheckResult Check() const;
};

// D(x, y, v) = distance from p(x, y) along -v to the first hit; MdfNoHit()
// where the ray leaves the slab (through-holes).
core::Mdf ComputeTrueMdf(const MesostructureScene& scene, const GroundTruthOptions& options);

// One view of the BTF, in the layout of FullBtf::view_images (3 channels,
// W x H * Nlight). T = f_r(n, l, v) (n . l) / cos(theta_l) at the first hit
// seen along -v, zero where that point is shadowed from l or faces away, so a
// flat Lambertian sample has T = albedo / pi. Rays through holes see a black
// backing (T = 0). Each texel's T is the mean over samples_per_side^2 rays
// from points of its area.
core::Image RenderTrueBtfView(const MesostructureScene& scene, const GroundTruthOptions& options, int view);
// Every view of it, in memory (for small grids: tests and benchmarks).
core::FullBtf RenderTrueBtf(const MesostructureScene& scene, const GroundTruthOptions& options);

// La(x, y, v) = sum over lights of T(x, y, v, l) cos(theta_l) w_l (the
// light set's solid-angle weights): the radiance under a uniform sky of unit
// radiance. Adds one view's contribution from its BTF view image.
void AccumulateAmbientTerm(const core::Image& btf_view, const core::SamplingSet& lights, int view,
                           formats::AmbientTerm* ambient);

// Writes the whole ground-truth material package (MDF in both forms, full
// BTF, ambient term and, when given, the rig's true calibration) into `out`;
// atomic. Reports progress per view in the given style.
void WriteGroundTruthPackage(const MesostructureScene& scene, const GroundTruthOptions& options,
                             const formats::Calibration* calibration, const std::string& source,
                             const std::filesystem::path& out, bool replace,
                             core::Progress::Style progress = core::Progress::Style::kAuto);

}  // namespace mesocap::sim
