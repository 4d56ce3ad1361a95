// The GenICam pixel formats mesocap reads from a camera (PFNC codes, as
// Aravis names them in arvenums.h) and their decoding into the linear
// [0, 1] images the camera interface promises.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/image.h"

namespace mesocap::drivers::aravis {

// Which colour the top-left photosite of a Bayer mosaic sees (GenICam's
// name: BayerRG = R G / G B).
enum class BayerPattern { kNone, kRG, kGR, kGB, kBG };

struct PixelFormatTraits {
  std::uint32_t code = 0;   // PFNC / GigE Vision pixel format code
  std::string name;         // GenICam enumeration entry
  int channels = 1;         // of the decoded image: 1 mono, 3 RGB (Bayer decodes to 3)
  int bit_depth = 8;        // significant bits a value
  int bytes_per_value = 1;  // 1, or 2 for a little-endian 16-bit container
  BayerPattern bayer = BayerPattern::kNone;
};

// Every format DecodePixels reads: Mono8/10/12/16, RGB8/10/12 (GigE
// Vision's RGB10Packed and RGB12Packed hold 16 bits a channel), Bayer 8 and
// 12 in all four orders.
const std::vector<PixelFormatTraits>& SupportedPixelFormats();
std::optional<PixelFormatTraits> FindPixelFormat(std::uint32_t code);
std::optional<PixelFormatTraits> FindPixelFormat(const std::string& name);

// Decodes one frame of `width` x `height` pixels. Values are code / (2^bit
// depth - 1); Bayer mosaics are demosaiced (OpenCV's bilinear), so an RGB
// camera and a Bayer camera give the same kind of image. Returns the number
// of saturated pixels: pixels with a channel at the top code (for a mosaic,
// photosites at the top code). Throws Error when `data` is shorter than the
// frame.
std::uint64_t DecodePixels(std::span<const std::byte> data, int width, int height, const PixelFormatTraits& format,
                           core::Image& image);

// The inverse, for a served camera: codes round(value * (2^bit depth - 1)),
// clamped, in the format's layout (not for Bayer formats). `data` must hold
// width * height * channels * bytes_per_value bytes.
void EncodePixels(const core::Image& image, const PixelFormatTraits& format, std::span<std::byte> data);

}  // namespace mesocap::drivers::aravis
