#include "core/image.h"

#include <string>

#include "core/error.h"

namespace mesocap::core {

Image::Image(int width, int height, int channels, float fill) : width_(width), height_(height), channels_(channels) {
  if (width <= 0 || height <= 0) {
    throw Error("image size must be positive, got " + std::to_string(width) + "x" + std::to_string(height));
  }
  if (channels < 1 || channels > 4) {
    throw Error("image channel count must be 1 to 4, got " + std::to_string(channels));
  }
  data_.assign(static_cast<std::size_t>(width) * height * channels, fill);
}

CheckResult CheckImageSize(int width, int height, std::string_view what) {
  if (width >= 1 && width <= kMaxImageSide && height >= 1 && height <= kMaxImageSide) return {};
  return std::string(what) + " " + std::to_string(width) + "x" + std::to_string(height) + " outside 1.." +
         std::to_string(kMaxImageSide);
}

Image ChannelMean(Image image) {
  if (image.channels() == 1) return image;
  Image mean(image.width(), image.height(), 1);
  const std::size_t pixels = static_cast<std::size_t>(image.width()) * image.height();
  const int channels = image.channels();
  for (std::size_t p = 0; p < pixels; ++p) {
    float sum = 0.0f;
    for (int c = 0; c < channels; ++c) sum += image.data()[p * channels + c];
    mean.data()[p] = sum / static_cast<float>(channels);
  }
  return mean;
}

}  // namespace mesocap::core
