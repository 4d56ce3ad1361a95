// The Bonn round trips' material and measures, shared by the conversions'
// tests (tests/bonn) and the export and import jobs' tests
// (tests/pipelines): the exact BTF of a small scene, a package holding it,
// the worst error against a per-value bound, and the sum of a Bonn file's
// factor terms that bounds their rounding.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>

#include "core/btf.h"
#include "formats/material_package.h"
#include "interop/bonn/bonn_btf_file.h"
#include "sim/ground_truth.h"
#include "sim/mesostructure_scene.h"

namespace mesocap::testing {

// The exact BTF of the `blocks` scene on a 6 x 4 texture (not square, so a
// swapped x and y shows) with 8 views and 6 lights.
inline const core::FullBtf& TrueBtf() {
  static const core::FullBtf btf = [] {
    sim::GroundTruthOptions gt;
    gt.texels.width = 6;
    gt.texels.height = 4;
    gt.texels.sample_size_mm = 12.0;
    gt.views = core::SamplingSet::Named("grid4x2");
    gt.lights = core::SamplingSet::Named("grid3x2");
    return sim::RenderTrueBtf(*sim::MakeBuiltinScene("blocks"), gt);
  }();
  return btf;
}

inline formats::MaterialPackage PackageOf(const core::FullBtf& btf) {
  formats::MaterialPackage p;
  p.description.name = "blocks";
  p.description.width = btf.width;
  p.description.height = btf.height;
  p.description.physical_size_mm = {12.0, 8.0};
  p.description.d_max_mm = 1.5;
  p.description.view_directions = btf.views;
  p.description.light_directions = btf.lights;
  p.full_btf = btf;
  return p;
}

// Largest |a - b| / bound over every value, bound(x, y, v, l, c) given.
template <typename Bound>
double WorstRatio(const core::FullBtf& want, const std::function<core::Image(int)>& got_view, Bound bound) {
  double worst = 0.0;
  for (int v = 0; v < want.view_count(); ++v) {
    const core::Image got = got_view(v);
    for (int l = 0; l < want.light_count(); ++l)
      for (int y = 0; y < want.height; ++y)
        for (int x = 0; x < want.width; ++x)
          for (int c = 0; c < 3; ++c) {
            const double d = std::abs(got.at(x, l * want.height + y, c) - want.at(x, y, v, l)[c]);
            worst = std::max(worst, d / bound(x, y, v, l, c));
          }
  }
  return worst;
}

// sum_k |U| |SxV| of one value of a Bonn file (either orientation): what
// bounds the rounding of its factors.
inline double TermSum(const bonn::BonnBtfFile& b, int x, int y, int v, int l, int c) {
  const int t = x + b.width * y, j = l + b.light_count() * v;
  const bool fmf = b.form == bonn::BonnBtfForm::kFmf;
  const bonn::BonnFactors& f = b.factors[fmf ? 0 : c];
  const bool texel_rows = b.row_space == bonn::BonnRowSpace::kTexels;
  // The FMF's channel is part of U's row index, channel fastest.
  const int u_row = (fmf ? 3 : 1) * (texel_rows ? t : j) + (fmf ? c : 0);
  const int sxv_row = texel_rows ? j : t;
  return (f.u.row(u_row).cwiseAbs().array() * f.sxv.row(sxv_row).cwiseAbs().array()).sum();
}

}  // namespace mesocap::testing
