// The bidirectional texture function T(x, y, view, light): linear RGB
// reflectance (docs/ARCHITECTURE.md), in the two forms a material package holds.
//
// Full form: one image per view direction, W wide and H * Nlight tall, light
// l in rows [l*H, (l+1)*H) -- lights packed along the 3rd axis, as Wang et
// al. 2005 Sec. 5 packs the eigenmaps into 3D textures. A view is the unit of
// reading and writing, so a large BTF never has to be in memory at once
// (material_package.h: ReadFullBtfView, MaterialPackageWriter).
//
// Factored form (Sec. 5): the BTF as a matrix A, factored by SVD and truncated
// to rank K, A ~= sum_k r_k c_k^T, with the singular values folded into the
// row factors (r_k = sigma_k u_k, c_k = v_k), so reconstruction is a plain
// sum of products. The matrix layouts:
//   paper:     rows (x, y, light), columns view -- the paper's eigenmaps
//              E_k(x, y, light) and weight maps W_k(view);
//   per_texel: rows (x, y), columns (view, light), column index
//              view * Nlight + light;
//   clustered: per_texel's, one matrix per cluster of texels;
//   per_view:  one matrix per view, rows (x, y), columns light (Sattler et
//              al. 2003's per-view factorisation: eigen-textures of each view
//              weighted per light).
// Each of the 3 colour channels is factored separately, either the RGB
// channels themselves or the channels of a decorrelating transform
// (luminance/chroma), c = rgb_to_factored * rgb.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/enum_text.h"
#include "core/image.h"
#include "core/sampling_set.h"

namespace mesocap::core {

struct FullBtf {
  int width = 0;
  int height = 0;
  SamplingSet views;
  SamplingSet lights;
  // One per view: 3 channels, width x height * lights.size().
  std::vector<Image> view_images;

  int view_count() const { return views.size(); }
  int light_count() const { return lights.size(); }
  Eigen::Vector3f at(int x, int y, int view, int light) const {
    const float* p = view_images[view].pixel(x, light * height + y);
    return {p[0], p[1], p[2]};
  }
};

// The full BTF read a range of view-image rows at a time, so that a pass
// over a BTF larger than memory (compression, its error: a paper rig's,
// docs/FORMATS.md "The full BTF") holds only the rows it works on. From a
// FullBtf in memory (InMemoryFullBtfReader) or from a material package's view
// files (material_package.h: PackageFullBtfReader). ReadRows may run
// concurrently for different views (a band is read view by view in
// parallel); calls for the same view are serialized by the implementation.
class FullBtfReader {
 public:
  FullBtfReader(int width, int height, SamplingSet views, SamplingSet lights);
  virtual ~FullBtfReader() = default;

  int width() const { return width_; }
  int height() const { return height_; }
  const SamplingSet& views() const { return views_; }
  const SamplingSet& lights() const { return lights_; }
  int view_count() const { return views_.size(); }
  int light_count() const { return lights_.size(); }

  // Rows [first_row, first_row + rows) of view `view`'s image (3 channels,
  // width x height * Nlight, light l in rows [l*H, (l+1)*H)) into `out`
  // (3 * width * rows floats). Throws Error for a view or rows out of range,
  // an unreadable source, or a non-finite value (naming the source, the
  // texel, the light and the channel).
  void ReadRows(int view, int first_row, int rows, float* out);

 protected:
  // What the messages name for view `view` ("BTF view 3", a file).
  virtual std::string Source(int view) const = 0;
  virtual void ReadRowsFromSource(int view, int first_row, int rows, float* out) = 0;

 private:
  int width_ = 0;
  int height_ = 0;
  SamplingSet views_;
  SamplingSet lights_;
};

class InMemoryFullBtfReader : public FullBtfReader {
 public:
  // `btf` must outlive the reader. Throws Error when its view images do not
  // have the sizes its directions imply.
  explicit InMemoryFullBtfReader(const FullBtf& btf);

 protected:
  std::string Source(int view) const override;
  void ReadRowsFromSource(int view, int first_row, int rows, float* out) override;

 private:
  const FullBtf& btf_;
};

// A full BTF of the given size, all zero. Throws Error on empty direction sets
// or a view image too tall for one image.
FullBtf MakeFullBtf(int width, int height, SamplingSet views, SamplingSet lights);

enum class BtfFactorLayout { kPaper, kPerTexel, kClustered, kPerView };
enum class BtfFactorColor { kRgb, kYCbCr };

constexpr auto EnumNamesOf(BtfFactorLayout) { return std::to_array({"paper", "per_texel", "clustered", "per_view"}); }
constexpr auto EnumNamesOf(BtfFactorColor) { return std::to_array({"rgb", "ycbcr"}); }

// Linear RGB to (Y, Cb, Cr) with the ITU-R BT.601 luma weights and no
// offsets (the data are linear and signed chroma is fine for factors).
Eigen::Matrix3d YCbCrFromLinearRgbBt601();

struct FactoredBtf {
  int width = 0;
  int height = 0;
  SamplingSet views;
  SamplingSet lights;
  BtfFactorLayout layout = BtfFactorLayout::kPaper;
  BtfFactorColor color = BtfFactorColor::kRgb;
  // The factored channels are rgb_to_factored * rgb. Ignored (identity) for
  // kRgb; for kYCbCr any invertible matrix, recorded in the manifest.
  Eigen::Matrix3d rgb_to_factored = Eigen::Matrix3d::Identity();
  // Row factors r_k (singular values folded in), one image per k, 3 channels:
  // paper: width x height * Nlight (light l in rows [l*H, (l+1)*H));
  // per_view: width x height * Nview (view v in rows [v*H, (v+1)*H));
  // per_texel and clustered: width x height.
  std::vector<Image> rows;
  // Column factors: column_count() wide, rank() tall (row k holds c_k),
  // 3 channels; clustered: rank() * cluster_count tall, cluster c's c_k in
  // row c * rank() + k; per_view: rank() * Nview tall, view v's c_k in row
  // v * rank() + k.
  Image columns;
  // clustered (local PCA, Mueller et al. 2003): each texel's cluster,
  // width * height ids (row-major) in 0..cluster_count-1; the texels of a
  // cluster share its column factors. Empty and 1 for the other layouts.
  std::vector<int> texel_clusters;
  int cluster_count = 1;

  int rank() const { return static_cast<int>(rows.size()); }
  int view_count() const { return views.size(); }
  int light_count() const { return lights.size(); }
  // Height of each row-factor image.
  int row_image_height() const {
    return layout == BtfFactorLayout::kPaper     ? height * light_count()
           : layout == BtfFactorLayout::kPerView ? height * view_count()
                                                 : height;
  }
  int column_count() const {
    return layout == BtfFactorLayout::kPaper     ? view_count()
           : layout == BtfFactorLayout::kPerView ? light_count()
                                                 : view_count() * light_count();
  }
  // How many sets of rank() column factors `columns` holds: one per cluster
  // (clustered), per view (per_view), else one.
  int column_sets() const {
    return layout == BtfFactorLayout::kClustered ? cluster_count
           : layout == BtfFactorLayout::kPerView ? view_count()
                                                 : 1;
  }
  // The row of `columns` that holds c_k for texel (x, y) seen from `view`.
  int column_row(int x, int y, int view, int k) const {
    return layout == BtfFactorLayout::kClustered ? texel_clusters[static_cast<std::size_t>(y) * width + x] * rank() + k
           : layout == BtfFactorLayout::kPerView ? view * rank() + k
                                                 : k;
  }

  // T(x, y, view, light) as linear RGB: sum_k r_k c_k per factored channel,
  // then back to RGB. Sizes must agree (CheckShape). A reference path: it
  // inverts rgb_to_factored on every call for kYCbCr.
  Eigen::Vector3f Reconstruct(int x, int y, int view, int light) const;
  // Throws Error when the factor images do not have the sizes above, the
  // rank is outside 1..min(100, column_count()), the colour matrix is not
  // invertible, rank * column_sets() is over kMaxBtfColumnRows, or
  // (clustered) the cluster count is outside 1..kMaxBtfClusters or a texel's
  // cluster out of range.
  void CheckShape() const;
};

// The largest rank a package can name (files rows_00 .. rows_99).
inline constexpr int kMaxBtfRank = 100;
// Clusters of a clustered factored BTF, and rows of its column factors (a
// texture the renderer holds whole: 16384 is OpenGL 4.5's least maximum
// texture size).
inline constexpr int kMaxBtfClusters = 1024;
inline constexpr int kMaxBtfColumnRows = 16384;

}  // namespace mesocap::core
