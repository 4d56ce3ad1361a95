#include "interop/bonn/bonn_interop.h"

#include <Eigen/LU>
#include <array>
#include <cmath>

#include "interop/bonn/ubo_sampling_sets.h"

namespace mesocap::bonn {
namespace fs = std::filesystem;
namespace {

// btflib's restore_dynamic_range.m: the stored values are log(value + eps).
constexpr double kDynamicRangeEps = 1e-5;

// Splits the term a b^T (a: U's side, b: SxV's side) into U = a / |a| (a
// unit vector, what btflib calls U), SxV = b |a|, S = |a| |b|: the same
// product, with U well inside the half range whatever the sizes.
void PutComponent(const Eigen::VectorXd& a, const Eigen::VectorXd& b, int k, BonnFactors* f) {
  const double an = a.norm();
  f->singular_values[k] = static_cast<float>(an * b.norm());
  if (an > 0.0) {
    f->u.col(k) = (a / an).cast<float>();
    f->sxv.col(k) = (b * an).cast<float>();
  } else {
    f->u.col(k).setZero();
    f->sxv.col(k).setZero();
  }
}

BonnFactors MakeFactors(Eigen::Index rows, Eigen::Index columns, int rank) {
  BonnFactors f;
  f.singular_values.setZero(rank);
  f.u.setZero(rows, rank);
  f.sxv.setZero(columns, rank);
  return f;
}

core::SamplingSet BonnSet(const std::vector<BonnDirection>& dirs, const fs::path& file, const char* field) {
  std::vector<core::SphericalAngles> angles;
  for (const auto& d : dirs) angles.push_back(AnglesFromBonn(d));
  // Snap to a named set when the file holds its directions in its order
  // (the float angles are within ~1e-7 rad of them).
  for (const char* name : {"ubo2014", "ubo2003"}) {
    const core::SamplingSet named = NamedSamplingSet(name);
    if (named.size() != static_cast<int>(angles.size())) continue;
    bool same = true;
    for (int i = 0; i < named.size() && same; ++i) {
      same = named.direction(i).dot(core::DirectionFromAngles(angles[i].theta, angles[i].phi)) > std::cos(1e-5);
    }
    if (same) return named;
  }
  try {
    return core::SamplingSet::FromAngles("bonn_file", angles);
  } catch (const core::Error& e) {
    throw core::FormatError(file, field, e.what());
  }
}

// 1 / cos(theta_l) per light when the data carry the light's cosine.
std::vector<double> CosineDivisors(const BonnBtfFile& btf) {
  std::vector<double> out(btf.light_count(), 1.0);
  if (btf.cosine_flag) {
    for (int l = 0; l < btf.light_count(); ++l) out[l] = 1.0 / std::cos(static_cast<double>(btf.lights[l].theta));
  }
  return out;
}

}  // namespace

BonnBtfFile BonnDfmfFromFactored(const core::FactoredBtf& btf) {
  btf.CheckShape();
  if (btf.layout != core::BtfFactorLayout::kPerTexel) {
    throw core::Error("DFMF export needs the per_texel layout (rows x, y; columns view, light), got " +
                      std::string(ToString(btf.layout)));
  }
  BonnBtfFile b;
  b.form = BonnBtfForm::kDfmf;
  b.row_space = BonnRowSpace::kDirections;
  b.width = btf.width;
  b.height = btf.height;
  for (int v = 0; v < btf.view_count(); ++v) b.views.push_back(BonnFromAngles(btf.views.angles(v)));
  for (int l = 0; l < btf.light_count(); ++l) b.lights.push_back(BonnFromAngles(btf.lights.angles(l)));
  if (btf.color == core::BtfFactorColor::kYCbCr) {
    // btflib's PCA model: rgb = M_file^T f + mean, so M_file = (M^-1)^T.
    b.color_model = kBonnColorPca;
    b.color_matrix = btf.rgb_to_factored.inverse().transpose().cast<float>();
  }
  const int texels = btf.width * btf.height;
  const int nl = btf.light_count(), nv = btf.view_count();
  for (int c = 0; c < 3; ++c) {
    BonnFactors f = MakeFactors(nl * nv, texels, btf.rank());
    for (int k = 0; k < btf.rank(); ++k) {
      Eigen::VectorXd r(texels), col(nl * nv);
      for (int y = 0; y < btf.height; ++y)
        for (int x = 0; x < btf.width; ++x) r[x + btf.width * y] = btf.rows[k].at(x, y, c);
      // mesocap column view * Nlight + light is btflib's light + Nlight * view.
      for (int j = 0; j < nl * nv; ++j) col[j] = btf.columns.at(j, k, c);
      PutComponent(col, r, k, &f);
    }
    b.factors.push_back(std::move(f));
  }
  return b;
}

BonnBtfFile BonnFmfFromFullBtf(const core::FullBtf& btf, const btf::BtfCompressionOptions& options,
                               btf::BtfCompressionReport* report) {
  const int w = btf.width, h = btf.height, nl = btf.light_count(), nv = btf.view_count();
  // The database's FMF factors one matrix with rows (channel, light, view),
  // channel fastest, and columns (x, y); its SVD is that of the transpose,
  // texels x (channel, light, view). CompressBtf's per_texel layout factors
  // texels x (view, light) per channel: put channel c of light l at light
  // 3 l + c (channel 0) of a BTF with 3 Nlight lights, and its column
  // view * 3 Nlight + 3 l + c is the FMF row c + 3 (l + Nlight view).
  // Channels 1 and 2 stay zero, which CompressBtf factors as zero; the
  // stand-in light set only carries the count.
  core::FullBtf stacked = core::MakeFullBtf(w, h, btf.views, core::SamplingSet::RegularGrid(3 * nl, 1));
  for (int v = 0; v < nv; ++v)
    for (int l = 0; l < nl; ++l)
      for (int c = 0; c < 3; ++c)
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x)
            stacked.view_images[v].pixel(x, (3 * l + c) * h + y)[0] = btf.view_images[v].pixel(x, l * h + y)[c];
  btf::BtfCompressionOptions o = options;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.color = core::BtfFactorColor::kRgb;
  const core::FactoredBtf factored = btf::CompressBtf(stacked, o, report);
  stacked = core::FullBtf{};

  BonnBtfFile b;
  b.form = BonnBtfForm::kFmf;
  b.row_space = BonnRowSpace::kDirections;
  b.width = w;
  b.height = h;
  for (int v = 0; v < nv; ++v) b.views.push_back(BonnFromAngles(btf.views.angles(v)));
  for (int l = 0; l < nl; ++l) b.lights.push_back(BonnFromAngles(btf.lights.angles(l)));
  BonnFactors f = MakeFactors(3 * nl * nv, w * h, factored.rank());
  for (int k = 0; k < factored.rank(); ++k) {
    Eigen::VectorXd r(w * h), col(3 * nl * nv);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) r[x + w * y] = factored.rows[k].at(x, y, 0);
    for (int j = 0; j < 3 * nl * nv; ++j) col[j] = factored.columns.at(j, k, 0);
    PutComponent(col, r, k, &f);
  }
  b.factors.push_back(std::move(f));
  return b;
}

core::SamplingSet BonnViewSet(const BonnBtfFile& btf, const fs::path& file) {
  return BonnSet(btf.views, file, "views");
}
core::SamplingSet BonnLightSet(const BonnBtfFile& btf, const fs::path& file) {
  return BonnSet(btf.lights, file, "lights");
}

core::FactoredBtf FactoredFromBonn(const BonnBtfFile& btf, const fs::path& file) {
  if (btf.dynamic_range_reduction != 0) {
    throw core::Error(file.string() + ": the FMF stores log values (dynamic_range_reduction " +
                      std::to_string(btf.dynamic_range_reduction) +
                      "), which no linear factorization reproduces; import it as a full BTF");
  }
  BonnColorTransform color;
  try {
    color = BonnToRgb(btf);
  } catch (const core::Error& e) {
    throw core::FormatError(file, "color_model", e.what());
  }
  const bool has_offset = color.offset.squaredNorm() > 0.0;
  int rank = 0;
  for (const auto& f : btf.factors) rank = std::max(rank, f.rank());
  rank += has_offset ? 1 : 0;
  if (rank > core::kMaxBtfRank) {
    throw core::Error(file.string() + ": " + std::to_string(rank) +
                      " components, more than a material package holds (" + std::to_string(core::kMaxBtfRank) +
                      "); import it as a full BTF (--btf full) and factor it with `mesocap compress`");
  }
  const int w = btf.width, h = btf.height, nl = btf.light_count(), nv = btf.view_count();
  core::FactoredBtf out;
  out.width = w;
  out.height = h;
  out.views = BonnViewSet(btf, file);
  out.lights = BonnLightSet(btf, file);
  out.layout = core::BtfFactorLayout::kPerTexel;
  if (btf.form == BonnBtfForm::kDfmf && btf.color_model != kBonnColorRgb) {
    const double det = color.to_rgb.determinant();
    if (!(std::abs(det) >= 1e-9 * std::pow(color.to_rgb.norm(), 3))) {
      throw core::FormatError(file, "color_transformation_matrix", "expected an invertible colour matrix");
    }
    out.color = core::BtfFactorColor::kYCbCr;
    out.rgb_to_factored = color.to_rgb.inverse();
  }
  out.rows.assign(rank, core::Image(w, h, 3));
  out.columns = core::Image(nl * nv, rank, 3);
  const std::vector<double> cosine = CosineDivisors(btf);
  const bool texel_rows = btf.row_space == BonnRowSpace::kTexels;
  // Column j = view * Nlight + light = btflib's direction index.
  auto column_scale = [&](int j) { return static_cast<float>(cosine[j % nl]); };
  for (int c = 0; c < 3; ++c) {
    const BonnFactors& f = btf.factors[btf.form == BonnBtfForm::kFmf ? 0 : c];
    const int channels = btf.form == BonnBtfForm::kFmf ? 3 : 1;
    const int offset = btf.form == BonnBtfForm::kFmf ? c : 0;
    const BonnMatrix& texel_side = texel_rows ? f.u : f.sxv;
    const BonnMatrix& direction_side = texel_rows ? f.sxv : f.u;
    // The channel is part of U's row index in an FMF (channel fastest).
    const int texel_channels = texel_rows ? channels : 1, texel_offset = texel_rows ? offset : 0;
    const int direction_channels = texel_rows ? 1 : channels, direction_offset = texel_rows ? 0 : offset;
    for (int k = 0; k < f.rank(); ++k) {
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
          out.rows[k].at(x, y, c) = texel_side(texel_offset + texel_channels * (x + w * y), k);
      for (int j = 0; j < nl * nv; ++j) {
        out.columns.at(j, k, c) = direction_side(direction_offset + direction_channels * j, k) * column_scale(j);
      }
    }
  }
  if (has_offset) {
    // rgb = B f + m = B (f + B^-1 m): a constant added to each decorrelated
    // channel, i.e. one more rank-1 term (divided by the cosine like the rest).
    const Eigen::Vector3d shift = color.to_rgb.inverse() * color.offset;
    const int k = rank - 1;
    for (int c = 0; c < 3; ++c) {
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) out.rows[k].at(x, y, c) = static_cast<float>(shift[c]);
      for (int j = 0; j < nl * nv; ++j) out.columns.at(j, k, c) = column_scale(j);
    }
  }
  out.CheckShape();
  return out;
}

core::Image BonnBtfView(const BonnBtfFile& btf, int view) {
  const int w = btf.width, h = btf.height, nl = btf.light_count(), nv = btf.view_count();
  if (view < 0 || view >= nv) throw core::Error("Bonn BTF view " + std::to_string(view) + " out of range");
  const BonnColorTransform color = BonnToRgb(btf);
  const std::vector<double> cosine = CosineDivisors(btf);
  const bool texel_rows = btf.row_space == BonnRowSpace::kTexels;
  const int texels = w * h;
  // f[c](texel, light): the decorrelated channels of this view.
  std::array<Eigen::MatrixXf, 3> f;
  if (btf.form == BonnBtfForm::kFmf) {
    const BonnFactors& m = btf.factors[0];
    if (texel_rows) {
      // U rows c + 3 * texel; SxV rows light + Nlight * view.
      const Eigen::MatrixXf all = m.u * m.sxv.middleRows(static_cast<Eigen::Index>(nl) * view, nl).transpose();
      for (int c = 0; c < 3; ++c) {
        f[c].resize(texels, nl);
        for (int t = 0; t < texels; ++t) f[c].row(t) = all.row(c + 3 * t);
      }
    } else {
      // U rows c + 3 * (light + Nlight * view); SxV rows texels.
      const Eigen::MatrixXf all = m.sxv * m.u.middleRows(3 * static_cast<Eigen::Index>(nl) * view, 3 * nl).transpose();
      for (int c = 0; c < 3; ++c) {
        f[c].resize(texels, nl);
        for (int l = 0; l < nl; ++l) f[c].col(l) = all.col(c + 3 * l);
      }
    }
  } else {
    for (int c = 0; c < 3; ++c) {
      const BonnFactors& m = btf.factors[c];
      const BonnMatrix& texel_side = texel_rows ? m.u : m.sxv;
      const BonnMatrix& direction_side = texel_rows ? m.sxv : m.u;
      f[c] = texel_side * direction_side.middleRows(static_cast<Eigen::Index>(nl) * view, nl).transpose();
    }
  }
  core::Image out(w, h * nl, 3);
  for (int l = 0; l < nl; ++l)
    for (int t = 0; t < texels; ++t) {
      Eigen::Vector3d rgb = color.to_rgb * Eigen::Vector3d(f[0](t, l), f[1](t, l), f[2](t, l)) + color.offset;
      if (btf.dynamic_range_reduction != 0) rgb = rgb.array().exp() - kDynamicRangeEps;
      rgb *= cosine[l];
      float* p = out.pixel(t % w, l * h + t / w);
      for (int c = 0; c < 3; ++c) p[c] = static_cast<float>(rgb[c]);
    }
  return out;
}

}  // namespace mesocap::bonn
