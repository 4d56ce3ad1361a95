#include "core/btf.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "core/error.h"

namespace mesocap::core {
namespace {

// The images of a BTF pack one direction set along their height; it must fit
// an int.
int PackedHeight(int height, int count, const char* what) {
  if (count < 1) throw Error(std::string("a BTF needs at least one ") + what + " direction");
  const long long rows = static_cast<long long>(height) * count;
  if (rows > std::numeric_limits<int>::max()) {
    throw Error("BTF image of " + std::to_string(height) + " rows x " + std::to_string(count) + " " + what +
                " directions is too tall for one image");
  }
  return static_cast<int>(rows);
}

std::string SizeText(const Image& image) {
  return std::to_string(image.width()) + "x" + std::to_string(image.height()) + "x" + std::to_string(image.channels());
}

void ExpectSize(const Image& image, int width, int height, const std::string& what) {
  if (image.width() != width || image.height() != height || image.channels() != 3) {
    throw Error("factored BTF: " + what + " is " + SizeText(image) + ", expected " + std::to_string(width) + "x" +
                std::to_string(height) + "x3");
  }
}

}  // namespace

FullBtfReader::FullBtfReader(int width, int height, SamplingSet views, SamplingSet lights)
    : width_(width), height_(height), views_(std::move(views)), lights_(std::move(lights)) {
  if (width < 1 || height < 1) throw Error("a BTF needs at least one texel");
  PackedHeight(height, lights_.size(), "light");
  if (views_.size() < 1) throw Error("a BTF needs at least one view direction");
}

void FullBtfReader::ReadRows(int view, int first_row, int rows, float* out) {
  const int image_rows = height_ * light_count();
  if (view < 0 || view >= view_count() || first_row < 0 || rows < 0 || first_row > image_rows - rows) {
    throw Error("BTF reader: view " + std::to_string(view) + " rows " + std::to_string(first_row) + ".." +
                std::to_string(first_row + rows) + " outside " + std::to_string(view_count()) + " views of " +
                std::to_string(image_rows) + " rows");
  }
  ReadRowsFromSource(view, first_row, rows, out);
  const long long values = 3LL * width_ * rows;
  for (long long i = 0; i < values; ++i) {
    if (!std::isfinite(out[i])) {
      const long long pixel = i / 3;
      const int row = first_row + static_cast<int>(pixel / width_);
      throw Error(Source(view) + ": non-finite value " + std::to_string(out[i]) + " at texel (" +
                  std::to_string(pixel % width_) + ", " + std::to_string(row % height_) + "), light " +
                  std::to_string(row / height_) + ", channel " + std::to_string(i % 3) +
                  "; a BTF holds finite reflectance");
    }
  }
}

InMemoryFullBtfReader::InMemoryFullBtfReader(const FullBtf& btf)
    : FullBtfReader(btf.width, btf.height, btf.views, btf.lights), btf_(btf) {
  if (static_cast<int>(btf.view_images.size()) != btf.view_count()) {
    throw Error("BTF: " + std::to_string(btf.view_images.size()) + " view images for " +
                std::to_string(btf.view_count()) + " views");
  }
  for (int v = 0; v < btf.view_count(); ++v) {
    const Image& image = btf.view_images[v];
    if (image.width() != btf.width || image.height() != btf.height * btf.light_count() || image.channels() != 3) {
      throw Error("BTF view " + std::to_string(v) + " image is " + SizeText(image) + ", expected " +
                  std::to_string(btf.width) + "x" + std::to_string(btf.height * btf.light_count()) + "x3");
    }
  }
}

std::string InMemoryFullBtfReader::Source(int view) const { return "BTF view " + std::to_string(view); }

void InMemoryFullBtfReader::ReadRowsFromSource(int view, int first_row, int rows, float* out) {
  const float* begin = btf_.view_images[view].pixel(0, first_row);
  std::copy(begin, begin + 3LL * btf_.width * rows, out);
}

FullBtf MakeFullBtf(int width, int height, SamplingSet views, SamplingSet lights) {
  const int rows = PackedHeight(height, lights.size(), "light");
  if (views.size() < 1) throw Error("a BTF needs at least one view direction");
  FullBtf btf;
  btf.width = width;
  btf.height = height;
  btf.view_images.reserve(views.size());
  for (int v = 0; v < views.size(); ++v) btf.view_images.emplace_back(width, rows, 3);
  btf.views = std::move(views);
  btf.lights = std::move(lights);
  return btf;
}

Eigen::Matrix3d YCbCrFromLinearRgbBt601() {
  Eigen::Matrix3d m;
  m << 0.299, 0.587, 0.114,       //
      -0.168736, -0.331264, 0.5,  //
      0.5, -0.418688, -0.081312;
  return m;
}

Eigen::Vector3f FactoredBtf::Reconstruct(int x, int y, int view, int light) const {
  const int row = layout == BtfFactorLayout::kPaper     ? light * height + y
                  : layout == BtfFactorLayout::kPerView ? view * height + y
                                                        : y;
  const int column = layout == BtfFactorLayout::kPaper     ? view
                     : layout == BtfFactorLayout::kPerView ? light
                                                           : view * light_count() + light;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int k = 0; k < rank(); ++k) {
    const float* r = rows[k].pixel(x, row);
    const float* w = columns.pixel(column, column_row(x, y, view, k));
    for (int ch = 0; ch < 3; ++ch) c[ch] += static_cast<double>(r[ch]) * w[ch];
  }
  if (color == BtfFactorColor::kYCbCr) c = rgb_to_factored.inverse() * c;
  return c.cast<float>();
}

void FactoredBtf::CheckShape() const {
  if (width < 1 || height < 1) {
    throw Error("factored BTF: texture size " + std::to_string(width) + "x" + std::to_string(height) +
                " is not positive");
  }
  // The row images stack the lights (paper) or the views (per_view).
  PackedHeight(height, light_count(), "light");
  if (layout == BtfFactorLayout::kPerView) PackedHeight(height, view_count(), "view");
  if (view_count() < 1) throw Error("a BTF needs at least one view direction");
  const long long columns_wide = static_cast<long long>(view_count()) * light_count();
  if (columns_wide > std::numeric_limits<int>::max()) throw Error("factored BTF: too many columns");
  if (rank() < 1 || rank() > kMaxBtfRank || rank() > column_count()) {
    throw Error("factored BTF: rank " + std::to_string(rank()) + " outside 1.." +
                std::to_string(std::min(kMaxBtfRank, column_count())));
  }
  for (int k = 0; k < rank(); ++k) {
    ExpectSize(rows[k], width, row_image_height(), "row factor " + std::to_string(k));
  }
  const bool clustered = layout == BtfFactorLayout::kClustered;
  if (clustered) {
    if (cluster_count < 1 || cluster_count > kMaxBtfClusters) {
      throw Error("factored BTF: " + std::to_string(cluster_count) + " clusters, outside 1.." +
                  std::to_string(kMaxBtfClusters));
    }
    if (texel_clusters.size() != static_cast<std::size_t>(width) * height) {
      throw Error("factored BTF: " + std::to_string(texel_clusters.size()) + " texel clusters for " +
                  std::to_string(width) + "x" + std::to_string(height) + " texels");
    }
    for (const int c : texel_clusters) {
      if (c < 0 || c >= cluster_count) {
        throw Error("factored BTF: texel cluster " + std::to_string(c) + " outside 0.." +
                    std::to_string(cluster_count - 1));
      }
    }
  }
  if (static_cast<long long>(rank()) * column_sets() > kMaxBtfColumnRows) {
    throw Error("factored BTF: rank " + std::to_string(rank()) + " x " + std::to_string(column_sets()) +
                (clustered ? " clusters" : " views") + " is over " + std::to_string(kMaxBtfColumnRows) +
                " rows of column factors");
  }
  ExpectSize(columns, column_count(), rank() * column_sets(), "column factors");
  if (color == BtfFactorColor::kYCbCr) {
    const double scale = rgb_to_factored.norm();
    if (!rgb_to_factored.allFinite() || !(scale > 0) ||
        std::abs(rgb_to_factored.determinant()) < 1e-9 * scale * scale * scale) {
      throw Error("factored BTF: the colour transform is not invertible");
    }
  }
}

}  // namespace mesocap::core
