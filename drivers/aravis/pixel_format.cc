#include "drivers/aravis/pixel_format.h"

#include <arv.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "core/error.h"

namespace mesocap::drivers::aravis {
namespace {

PixelFormatTraits Traits(ArvPixelFormat code, std::string name, int channels, int bit_depth,
                         BayerPattern bayer = BayerPattern::kNone) {
  // The PFNC code's bits 16-23 are the bits a pixel occupies.
  const int bits_per_pixel = static_cast<int>((code >> 16) & 0xff);
  const int stored_channels = bayer == BayerPattern::kNone ? channels : 1;
  return {code, std::move(name), channels, bit_depth, bits_per_pixel / 8 / stored_channels, bayer};
}

// OpenCV names a mosaic by the second row's second and third photosites,
// GenICam by the first row's first two: GenICam RG is OpenCV BG.
int DemosaicCode(BayerPattern pattern) {
  switch (pattern) {
    case BayerPattern::kRG:
      return cv::COLOR_BayerBG2RGB;
    case BayerPattern::kGR:
      return cv::COLOR_BayerGB2RGB;
    case BayerPattern::kGB:
      return cv::COLOR_BayerGR2RGB;
    case BayerPattern::kBG:
      return cv::COLOR_BayerRG2RGB;
    case BayerPattern::kNone:
      break;
  }
  throw core::Error("not a Bayer pattern");
}

std::uint32_t ValueAt(const std::byte* p, int bytes) {
  if (bytes == 1) return static_cast<std::uint8_t>(*p);
  // Multi-byte PFNC values are little-endian.
  return static_cast<std::uint32_t>(static_cast<std::uint8_t>(p[0])) |
         (static_cast<std::uint32_t>(static_cast<std::uint8_t>(p[1])) << 8);
}

}  // namespace

const std::vector<PixelFormatTraits>& SupportedPixelFormats() {
  static const std::vector<PixelFormatTraits> formats = {
      Traits(ARV_PIXEL_FORMAT_MONO_8, "Mono8", 1, 8),
      Traits(ARV_PIXEL_FORMAT_MONO_10, "Mono10", 1, 10),
      Traits(ARV_PIXEL_FORMAT_MONO_12, "Mono12", 1, 12),
      Traits(ARV_PIXEL_FORMAT_MONO_16, "Mono16", 1, 16),
      Traits(ARV_PIXEL_FORMAT_RGB_8_PACKED, "RGB8", 3, 8),
      Traits(ARV_PIXEL_FORMAT_RGB_10_PACKED, "RGB10", 3, 10),
      Traits(ARV_PIXEL_FORMAT_RGB_12_PACKED, "RGB12", 3, 12),
      Traits(ARV_PIXEL_FORMAT_BAYER_RG_8, "BayerRG8", 3, 8, BayerPattern::kRG),
      Traits(ARV_PIXEL_FORMAT_BAYER_GR_8, "BayerGR8", 3, 8, BayerPattern::kGR),
      Traits(ARV_PIXEL_FORMAT_BAYER_GB_8, "BayerGB8", 3, 8, BayerPattern::kGB),
      Traits(ARV_PIXEL_FORMAT_BAYER_BG_8, "BayerBG8", 3, 8, BayerPattern::kBG),
      Traits(ARV_PIXEL_FORMAT_BAYER_RG_12, "BayerRG12", 3, 12, BayerPattern::kRG),
      Traits(ARV_PIXEL_FORMAT_BAYER_GR_12, "BayerGR12", 3, 12, BayerPattern::kGR),
      Traits(ARV_PIXEL_FORMAT_BAYER_GB_12, "BayerGB12", 3, 12, BayerPattern::kGB),
      Traits(ARV_PIXEL_FORMAT_BAYER_BG_12, "BayerBG12", 3, 12, BayerPattern::kBG),
  };
  return formats;
}

std::optional<PixelFormatTraits> FindPixelFormat(std::uint32_t code) {
  for (const auto& f : SupportedPixelFormats()) {
    if (f.code == code) return f;
  }
  return std::nullopt;
}

std::optional<PixelFormatTraits> FindPixelFormat(const std::string& name) {
  for (const auto& f : SupportedPixelFormats()) {
    if (f.name == name) return f;
  }
  return std::nullopt;
}

std::uint64_t DecodePixels(std::span<const std::byte> data, int width, int height, const PixelFormatTraits& format,
                           core::Image& image) {
  const int stored_channels = format.bayer == BayerPattern::kNone ? format.channels : 1;
  const std::size_t values = static_cast<std::size_t>(width) * height * stored_channels;
  if (data.size() < values * format.bytes_per_value) {
    throw core::Error("a " + format.name + " frame of " + std::to_string(width) + " x " + std::to_string(height) +
                      " needs " + std::to_string(values * format.bytes_per_value) + " bytes, got " +
                      std::to_string(data.size()));
  }
  const std::uint32_t top = (std::uint32_t{1} << format.bit_depth) - 1;
  const double max_code = static_cast<double>(top);
  if (image.width() != width || image.height() != height || image.channels() != format.channels) {
    image = core::Image(width, height, format.channels);
  }
  std::uint64_t saturated = 0;
  if (format.bayer == BayerPattern::kNone) {
    // The same division the simulated sensor makes (code / max code in
    // double, then float), so a served simulated frame decodes bit for bit.
    float* out = image.data();
    const std::byte* in = data.data();
    for (int p = 0; p < width * height; ++p) {
      bool at_top = false;
      for (int c = 0; c < format.channels; ++c) {
        const std::uint32_t code = std::min(ValueAt(in, format.bytes_per_value), top);
        in += format.bytes_per_value;
        at_top |= code == top;
        *out++ = static_cast<float>(code / max_code);
      }
      saturated += at_top ? 1 : 0;
    }
    return saturated;
  }
  const int depth = format.bytes_per_value == 1 ? CV_8U : CV_16U;
  cv::Mat mosaic(height, width, depth);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      const std::uint32_t code =
          std::min(ValueAt(data.data() + (static_cast<std::size_t>(y) * width + x) * format.bytes_per_value,
                           format.bytes_per_value),
                   top);
      saturated += code == top ? 1 : 0;
      if (depth == CV_8U) {
        mosaic.at<std::uint8_t>(y, x) = static_cast<std::uint8_t>(code);
      } else {
        mosaic.at<std::uint16_t>(y, x) = static_cast<std::uint16_t>(code);
      }
    }
  }
  cv::Mat rgb;
  cv::cvtColor(mosaic, rgb, DemosaicCode(format.bayer));
  cv::Mat values_mat(height, width, CV_32FC3, image.data());
  rgb.convertTo(values_mat, CV_32FC3, 1.0 / max_code);
  return saturated;
}

void EncodePixels(const core::Image& image, const PixelFormatTraits& format, std::span<std::byte> data) {
  if (format.bayer != BayerPattern::kNone) throw core::Error("cannot encode a Bayer mosaic");
  if (image.channels() != format.channels) {
    throw core::Error("a " + std::to_string(image.channels()) + "-channel image cannot be sent as " + format.name);
  }
  if (data.size() < image.size() * format.bytes_per_value) {
    throw core::Error("the " + format.name + " buffer holds " + std::to_string(data.size()) + " bytes, not " +
                      std::to_string(image.size() * format.bytes_per_value));
  }
  const double max_code = static_cast<double>((std::uint32_t{1} << format.bit_depth) - 1);
  std::byte* out = data.data();
  for (std::size_t i = 0; i < image.size(); ++i) {
    const double v = image.data()[i] > 0.0f ? image.data()[i] : 0.0;  // NaN reads as 0
    const auto code = static_cast<std::uint32_t>(std::clamp(std::round(v * max_code), 0.0, max_code));
    out[0] = static_cast<std::byte>(code & 0xff);
    if (format.bytes_per_value == 2) out[1] = static_cast<std::byte>(code >> 8);
    out += format.bytes_per_value;
  }
}

}  // namespace mesocap::drivers::aravis
