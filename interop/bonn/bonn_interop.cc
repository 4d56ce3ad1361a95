#include "interop/bonn/bonn_interop.h"

#include <spdlog/spdlog.h>

#include <Eigen/LU>
#include <array>
#include <chrono>
#include <cmath>

#include "btf/ambient_term.h"
#include "core/atomic_file.h"
#include "core/mdf.h"
#include "core/version.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"

namespace mesocap::bonn {
namespace fs = std::filesystem;
namespace {

// btflib's restore_dynamic_range.m: the stored values are log(value + eps).
constexpr double kDynamicRangeEps = 1e-5;

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The meta data a Bonn file takes from a package's description.
void FillBonnMeta(const formats::MaterialDescription& d, BonnBtfFile* b) {
  b->measurement_setup = (std::string("mesocap ") + core::Version() + ": " + d.name).substr(0, 80);
  b->pixels_per_mm = static_cast<float>(d.width / d.physical_size_mm.x());
}

// Splits r c^T into U = r / |r| (unit left vector, what btflib calls U),
// SxV = c |r|, S = |r| |c|: the same product, with U well inside the half
// range whatever the texture size.
void PutComponent(const Eigen::VectorXd& r, const Eigen::VectorXd& c, int k, BonnFactors* f) {
  const double rn = r.norm();
  f->singular_values[k] = static_cast<float>(rn * c.norm());
  if (rn > 0.0) {
    f->u.col(k) = (r / rn).cast<float>();
    f->sxv.col(k) = (c * rn).cast<float>();
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
    const core::SamplingSet named = core::SamplingSet::Named(name);
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

formats::MaterialDescription DescriptionFor(const std::string& name, int width, int height, double width_mm, double d_max_mm,
                                   core::SamplingSet views, core::SamplingSet lights, std::string source) {
  formats::MaterialDescription d;
  d.name = name;
  d.width = width;
  d.height = height;
  d.physical_size_mm = {width_mm, width_mm * height / width};
  d.d_max_mm = d_max_mm;
  d.view_directions = std::move(views);
  d.light_directions = std::move(lights);
  d.provenance.source = std::move(source);
  return d;
}

void WriteFlatMdf(const formats::MaterialDescription& d, formats::MaterialPackageWriter* writer) {
  core::Mdf mdf = core::MakeMdf(d.width, d.height, d.view_directions);
  std::fill(mdf.distance_mm.data(), mdf.distance_mm.data() + mdf.distance_mm.size(), 0.0f);
  writer->WriteMdf(mdf);
}

// The package's BTF in full, read or reconstructed from its factors.
core::FullBtf FullBtfOfPackage(const fs::path& package, const formats::MaterialManifest& manifest) {
  if (manifest.full_btf) return formats::ReadFullBtf(package, manifest);
  const core::FactoredBtf factored = formats::ReadFactoredBtf(package, manifest);
  core::FullBtf full = core::MakeFullBtf(factored.width, factored.height, factored.views, factored.lights);
  for (int v = 0; v < full.view_count(); ++v) full.view_images[v] = btf::ReconstructBtfView(factored, v);
  return full;
}

void ExpectNoTarget(const fs::path& out, bool replace) {
  std::error_code ec;
  if (!replace && fs::exists(out, ec)) throw core::Error(out.string() + " already exists (use --replace to overwrite it)");
}

}  // namespace

const char* ToString(BonnForm form) {
  switch (form) {
    case BonnForm::kUbo2003: return "ubo2003";
    case BonnForm::kFmf: return "fmf";
    case BonnForm::kDfmf: return "dfmf";
  }
  return "?";
}

core::CheckResult BonnExportOptions::Check() const {
  if (!(std::isfinite(scale) && scale > 0.0)) return "scale " + std::to_string(scale) + " must be a positive number";
  if (scalar == BonnScalar::kDouble) return "mesocap writes half or float factors";
  return compression.Check();
}

core::CheckResult BonnImportOptions::Check() const {
  if (!(std::isfinite(d_max_mm) && d_max_mm > 0.0)) {
    return "d_max_mm " + std::to_string(d_max_mm) + " must be a positive number (the Bonn forms carry no depth)";
  }
  if (!(std::isfinite(width_mm) && width_mm >= 0.0)) return "width_mm must be a positive number, or 0";
  if (!(std::isfinite(scale) && scale > 0.0)) return "scale " + std::to_string(scale) + " must be a positive number";
  return {};
}

BonnBtfFile BonnDfmfFromFactored(const core::FactoredBtf& btf) {
  btf.CheckShape();
  if (btf.layout != core::BtfFactorLayout::kPerTexel) {
    throw core::Error("DFMF export needs the per_texel layout (rows x, y; columns view, light), got " +
                std::string(ToString(btf.layout)));
  }
  BonnBtfFile b;
  b.form = BonnBtfForm::kDfmf;
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
    BonnFactors f = MakeFactors(texels, nl * nv, btf.rank());
    for (int k = 0; k < btf.rank(); ++k) {
      Eigen::VectorXd r(texels), col(nl * nv);
      for (int y = 0; y < btf.height; ++y)
        for (int x = 0; x < btf.width; ++x) r[x + btf.width * y] = btf.rows[k].at(x, y, c);
      // mesocap column view * Nlight + light is btflib's light + Nlight * view.
      for (int j = 0; j < nl * nv; ++j) col[j] = btf.columns.at(j, k, c);
      PutComponent(r, col, k, &f);
    }
    b.factors.push_back(std::move(f));
  }
  return b;
}

BonnBtfFile BonnFmfFromFullBtf(const core::FullBtf& btf, const btf::BtfCompressionOptions& options, btf::BtfCompressionReport* report) {
  const int w = btf.width, h = btf.height, nl = btf.light_count(), nv = btf.view_count();
  // The FMF matrix has rows (channel, x, y): stack the channels along y in
  // channel 0 of a BTF three times as tall, so that CompressBtf's per_texel
  // SVD of channel 0 is the SVD of that matrix (channels 1 and 2 stay zero,
  // which CompressBtf factors as zero).
  core::FullBtf stacked = core::MakeFullBtf(w, 3 * h, btf.views, btf.lights);
  for (int v = 0; v < nv; ++v)
    for (int l = 0; l < nl; ++l)
      for (int c = 0; c < 3; ++c)
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) stacked.view_images[v].pixel(x, l * 3 * h + c * h + y)[0] = btf.view_images[v].pixel(x, l * h + y)[c];
  btf::BtfCompressionOptions o = options;
  o.layout = core::BtfFactorLayout::kPerTexel;
  o.color = core::BtfFactorColor::kRgb;
  const core::FactoredBtf factored = btf::CompressBtf(stacked, o, report);
  stacked = core::FullBtf{};

  BonnBtfFile b;
  b.form = BonnBtfForm::kFmf;
  b.width = w;
  b.height = h;
  for (int v = 0; v < nv; ++v) b.views.push_back(BonnFromAngles(btf.views.angles(v)));
  for (int l = 0; l < nl; ++l) b.lights.push_back(BonnFromAngles(btf.lights.angles(l)));
  BonnFactors f = MakeFactors(3 * w * h, nl * nv, factored.rank());
  for (int k = 0; k < factored.rank(); ++k) {
    Eigen::VectorXd r(3 * w * h), col(nl * nv);
    for (int c = 0; c < 3; ++c)
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) r[c + 3 * (x + w * y)] = factored.rows[k].at(x, c * h + y, 0);
    for (int j = 0; j < nl * nv; ++j) col[j] = factored.columns.at(j, k, 0);
    PutComponent(r, col, k, &f);
  }
  b.factors.push_back(std::move(f));
  return b;
}

core::SamplingSet BonnViewSet(const BonnBtfFile& btf, const fs::path& file) { return BonnSet(btf.views, file, "views"); }
core::SamplingSet BonnLightSet(const BonnBtfFile& btf, const fs::path& file) { return BonnSet(btf.lights, file, "lights"); }

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
    throw core::Error(file.string() + ": " + std::to_string(rank) + " components, more than a material package holds (" +
                std::to_string(core::kMaxBtfRank) + "); import it as a full BTF (--btf full) and factor it with `mesocap compress`");
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
        for (int x = 0; x < w; ++x) out.rows[k].at(x, y, c) = texel_side(texel_offset + texel_channels * (x + w * y), k);
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

BonnExportReport ExportBonn(const fs::path& package, const fs::path& out, const BonnExportOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (const auto problem = options.Check(); !problem.empty()) throw core::Error("export bonn: " + problem);
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(package);
  if (!manifest.full_btf && !manifest.factored_btf) {
    throw core::Error("export bonn: " + package.string() + " holds no BTF (manifest.json has no btf part)");
  }
  const formats::MaterialDescription& d = manifest.description;
  BonnExportReport report;
  if (options.form == BonnForm::kUbo2003) {
    report.source = manifest.full_btf ? "full BTF" : "factored BTF, reconstructed";
    std::optional<core::FactoredBtf> factored;
    if (!manifest.full_btf) factored = formats::ReadFactoredBtf(package, manifest);
    core::AtomicDirectory folder(out, options.replace);
    for (int v = 0; v < d.view_directions.size(); ++v) {
      const core::Image view = factored ? btf::ReconstructBtfView(*factored, v) : formats::ReadFullBtfView(package, manifest, v);
      report.clipped_values += WriteUbo2003View(folder.temp_path(), d.view_directions, d.light_directions, v, view,
                                                options.encoding, options.scale);
    }
    folder.Commit();
    report.files = static_cast<long long>(d.view_directions.size()) * d.light_directions.size();
    if (report.clipped_values > 0) {
      spdlog::warn("{} of {} values fell outside [0, 1] after scaling by {} and were clipped to 8 bits; "
                   "choose --scale so the brightest value maps to at most 1, or write EXR",
                   report.clipped_values, report.files * d.width * d.height * 3, options.scale);
    }
  } else {
    ExpectNoTarget(out, options.replace);
    BonnBtfFile file;
    if (options.form == BonnForm::kDfmf) {
      if (manifest.factored_btf && manifest.factored_btf->layout == core::BtfFactorLayout::kPerTexel) {
        report.source = "per_texel factored BTF";
        file = BonnDfmfFromFactored(formats::ReadFactoredBtf(package, manifest));
      } else {
        report.source = manifest.full_btf ? "full BTF, factored per_texel" : "paper-layout factors, refactored per_texel";
        btf::BtfCompressionOptions o = options.compression;
        o.layout = core::BtfFactorLayout::kPerTexel;
        btf::BtfCompressionReport compression;
        file = BonnDfmfFromFactored(btf::CompressBtf(FullBtfOfPackage(package, manifest), o, &compression));
        report.compression = compression;
      }
    } else {
      report.source = manifest.full_btf ? "full BTF, factored as one matrix" : "factored BTF, refactored as one matrix";
      btf::BtfCompressionReport compression;
      file = BonnFmfFromFullBtf(FullBtfOfPackage(package, manifest), options.compression, &compression);
      report.compression = compression;
    }
    FillBonnMeta(d, &file);
    report.rank = 0;
    for (const auto& f : file.factors) report.rank = std::max(report.rank, f.rank());
    WriteBonnBtfFile(out, file, options.scalar);
    report.files = 1;
  }
  report.seconds = SecondsSince(start);
  return report;
}

BonnImportReport ImportBonn(const fs::path& in, const fs::path& out, const BonnImportOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (const auto problem = options.Check(); !problem.empty()) throw core::Error("import bonn: " + problem);
  std::error_code ec;
  fs::path named = in;
  if (named.filename().empty()) named = named.parent_path();  // "folder/"
  const std::string name = !options.name.empty()           ? options.name
                           : fs::is_directory(in, ec) ? named.filename().string()
                                                      : named.stem().string();
  BonnImportReport report;
  nlohmann::json facts;
  if (fs::is_directory(in, ec)) {
    report.form = BonnForm::kUbo2003;
    const BonnImportParts parts = options.parts.value_or(BonnImportParts::kFull);
    if (parts != BonnImportParts::kFull) {
      throw core::Error("import bonn: " + in.string() + " is an image folder, which holds a full BTF only; import it with "
                  "--btf full and factor it with `mesocap compress`");
    }
    if (!(options.width_mm > 0.0)) {
      throw core::Error("import bonn: the images of " + in.string() + " carry no physical size; give --size-mm");
    }
    const Ubo2003ImageSet set = ScanUbo2003Folder(in);
    const formats::MaterialDescription d = DescriptionFor(name, set.width, set.height, options.width_mm, options.d_max_mm,
                                                 set.views, set.lights, "import bonn ubo2003 " + in.string());
    formats::MaterialPackageWriter writer(out, d, options.replace);
    formats::AmbientTerm ambient = btf::MakeAmbientTerm(d.width, d.height, d.view_directions);
    for (int v = 0; v < d.view_directions.size(); ++v) {
      const core::Image view = ReadUbo2003View(set, v, options.scale);
      writer.WriteFullBtfView(v, view);
      btf::AddAmbientView(view, d.light_directions, v, &ambient);
    }
    writer.WriteAmbientTerm(ambient);
    if (options.flat_mdf) WriteFlatMdf(d, &writer);
    facts = {{"form", "ubo2003"}, {"images", d.view_directions.size() * d.light_directions.size()}, {"scale", options.scale}};
    writer.WriteErrorReport({{"bonn_import", facts}});
    report.manifest = writer.Commit();
  } else {
    const BonnBtfFile btf = ReadBonnBtfFile(in);
    report.form = btf.form == BonnBtfForm::kFmf ? BonnForm::kFmf : BonnForm::kDfmf;
    report.signature = btf.signature;
    const BonnImportParts parts = options.parts.value_or(BonnImportParts::kFactored);
    double width_mm = options.width_mm;
    if (!(width_mm > 0.0)) {
      if (!(btf.pixels_per_mm > 0.0f)) {
        throw core::FormatError(in, "meta.pixels_per_mm",
                          "is " + std::to_string(btf.pixels_per_mm) + ", so the physical size is unknown; give --size-mm");
      }
      width_mm = btf.width / static_cast<double>(btf.pixels_per_mm);
    }
    if (btf.rgb_scale_factor != Eigen::Vector3f::Ones()) {
      spdlog::warn("{}: RGB scale factor ({}, {}, {}) is not applied (btflib does not apply it either)", in.string(),
                   btf.rgb_scale_factor[0], btf.rgb_scale_factor[1], btf.rgb_scale_factor[2]);
    }
    std::optional<core::FactoredBtf> factored;
    if (parts != BonnImportParts::kFull) factored = FactoredFromBonn(btf, in);
    try {
      BonnToRgb(btf);  // a full import needs a linear colour model too: fail before writing anything
    } catch (const core::Error& e) {
      throw core::FormatError(in, "color_model", e.what());
    }
    const formats::MaterialDescription d =
        DescriptionFor(name, btf.width, btf.height, width_mm, options.d_max_mm, BonnViewSet(btf, in),
                       BonnLightSet(btf, in), std::string("import bonn ") + ToString(report.form) + " " + in.string());
    formats::MaterialPackageWriter writer(out, d, options.replace);
    formats::AmbientTerm ambient = btf::MakeAmbientTerm(d.width, d.height, d.view_directions);
    for (int v = 0; v < d.view_directions.size(); ++v) {
      // With a full BTF the ambient term integrates the exact decode; else
      // the factored BTF, which equals it up to float rounding.
      const core::Image view = parts != BonnImportParts::kFactored ? BonnBtfView(btf, v) : btf::ReconstructBtfView(*factored, v);
      if (parts != BonnImportParts::kFactored) writer.WriteFullBtfView(v, view);
      btf::AddAmbientView(view, d.light_directions, v, &ambient);
    }
    if (factored) {
      writer.WriteFactoredBtf(*factored);
      report.rank = factored->rank();
    }
    writer.WriteAmbientTerm(ambient);
    if (options.flat_mdf) WriteFlatMdf(d, &writer);
    facts = {{"form", ToString(report.form)},
             {"signature", btf.signature},
             {"scalar_bytes", static_cast<int>(btf.scalar)},
             {"color_model", BonnColorModelName(btf.color_model)},
             {"cosine_flag", btf.cosine_flag}};
    writer.WriteErrorReport({{"bonn_import", facts}});
    report.manifest = writer.Commit();
  }
  report.seconds = SecondsSince(start);
  return report;
}

}  // namespace mesocap::bonn
