// A float image with 1 to 4 interleaved channels, row-major, origin top-left.
// Values are linear (docs/ARCHITECTURE.md: BTF values are linear reflectance).
#pragma once

#include <cstddef>
#include <string_view>
#include <vector>

#include "core/error.h"

namespace mesocap::core {

// The largest image side mesocap accepts wherever a size comes from outside
// (a rig's camera images, a texel grid, a package's or a Bonn file's texture):
// above any sensor or texture a capture needs, and a size beyond it (a typo,
// a hostile header) is refused before anything is allocated for it.
inline constexpr int kMaxImageSide = 16384;

// Empty when both sides are in 1..kMaxImageSide, else why not, e.g.
// "texture size 0x64 outside 1..16384" for `what` = "texture size".
CheckResult CheckImageSize(int width, int height, std::string_view what);

class Image {
 public:
  Image() = default;
  // Throws Error on a non-positive size or a channel count outside 1..4.
  Image(int width, int height, int channels, float fill = 0.0f);

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  bool empty() const { return data_.empty(); }
  std::size_t size() const { return data_.size(); }

  float& at(int x, int y, int c = 0) { return data_[Index(x, y, c)]; }
  float at(int x, int y, int c = 0) const { return data_[Index(x, y, c)]; }
  float* data() { return data_.data(); }
  const float* data() const { return data_.data(); }
  // First channel of pixel (x, y).
  float* pixel(int x, int y) { return data_.data() + Index(x, y, 0); }
  const float* pixel(int x, int y) const { return data_.data() + Index(x, y, 0); }

 private:
  std::size_t Index(int x, int y, int c) const { return (static_cast<std::size_t>(y) * width_ + x) * channels_ + c; }

  int width_ = 0;
  int height_ = 0;
  int channels_ = 0;
  std::vector<float> data_;
};

// One channel: the mean of `image`'s channels at each pixel (`image` itself
// when it has one).
Image ChannelMean(Image image);

}  // namespace mesocap::core
