#include "core/image.h"

#include <string>

#include "core/error.h"

namespace mesocap {

Image::Image(int width, int height, int channels, float fill)
    : width_(width), height_(height), channels_(channels) {
  if (width <= 0 || height <= 0) {
    throw Error("image size must be positive, got " + std::to_string(width) + "x" +
                std::to_string(height));
  }
  if (channels < 1 || channels > 4) {
    throw Error("image channel count must be 1 to 4, got " + std::to_string(channels));
  }
  data_.assign(static_cast<std::size_t>(width) * height * channels, fill);
}

}  // namespace mesocap
