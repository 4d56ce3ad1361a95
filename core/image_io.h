// Reading and writing images through OpenImageIO: OpenEXR (half or float),
// JPEG (8 bit, baseline or progressive), PNG (8 or 16 bit), TIFF (8, 16 bit
// or float). Writes are atomic; reads name the file and the property they
// reject. Reads honour the EXIF orientation a camera writes (the image comes
// back upright, its size as displayed), except by rows, which refuse it.
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "core/enum_text.h"
#include "core/image.h"

namespace mesocap::core {

// How pixel values are stored in the file. Integer encodings map [0, 1] to
// the full code range (values outside are clamped); the container is chosen
// by the file extension (.exr, .jpg/.jpeg, .png, .tif/.tiff).
enum class PixelEncoding { kFloat32, kHalf, kUInt8, kUInt16 };

struct ImageHeader {
  int width = 0;
  int height = 0;
  int channels = 0;
  PixelEncoding encoding = PixelEncoding::kFloat32;
};

struct ImageReadOptions {
  // Upper bound on width * height * channels, checked against the header
  // before any pixel is allocated (1 GiB of floats by default).
  std::size_t max_values = std::size_t{1} << 28;
  // When positive, the file must have exactly this size / channel count.
  int expected_width = 0;
  int expected_height = 0;
  int expected_channels = 0;
  // When set, the file must store its samples so (a session's 16-bit frames).
  std::optional<PixelEncoding> expected_encoding;
};

ImageHeader ReadImageHeader(const std::filesystem::path& file);
// Whether `file` is an image ReadImageHeader reads: what --replace of an
// image output may replace.
bool IsImageFile(const std::filesystem::path& file);
Image ReadImage(const std::filesystem::path& file, const ImageReadOptions& options = {});
// Throws Error when the container cannot store `encoding` (PNG float, EXR
// 8-bit, JPEG anything but 8-bit).
void WriteImage(const std::filesystem::path& file, const Image& image,
                PixelEncoding encoding = PixelEncoding::kFloat32);

constexpr auto EnumNamesOf(PixelEncoding) { return std::to_array({"float32", "half", "uint8", "uint16"}); }

// `image` scaled down to fit within max_side x max_side pixels with
// OpenImageIO's filtered resize (`image` itself when it fits already).
Image ScaledToFit(const Image& image, int max_side);
// What people look at (a camera's live preview): the bytes of an 8-bit PNG
// file of `image`, sRGB-encoded from its linear values clamped to [0, 1].
std::string EncodePreviewPng(const Image& image);

// An OpenImageIO error for a message: its first line (OpenImageIO appends
// the image library's own lines, "PNG library error"), cut as core::Cut().
std::string ImageLibraryMessage(const std::string& error);
// Why a file could not be decoded, in the project's words ("the file is
// damaged, cut short or not PNG ..."): a decoder's own ("IDAT: invalid
// distances set") means nothing to a user, so it goes to the debug log.
std::string ImageDecodeFailure(const std::filesystem::path& file, const std::string& library_error);

// Reads an image a range of rows at a time, the file kept open between
// reads: how a pass over data larger than memory (a paper-rig BTF)
// holds only the rows it works on. Opening checks the header against
// `expected` (sizes, channel count; 0 = any) before any pixel is read.
class ImageRowReader {
 public:
  ImageRowReader(const std::filesystem::path& file, const ImageReadOptions& expected);
  ~ImageRowReader();
  ImageRowReader(const ImageRowReader&) = delete;
  ImageRowReader& operator=(const ImageRowReader&) = delete;

  const ImageHeader& header() const { return header_; }
  const std::filesystem::path& file() const { return file_; }
  // Rows [first_row, first_row + rows) as float, all channels interleaved,
  // into `out` (width * rows * channels values). Throws FormatError naming
  // the file for rows outside the image or a failed (truncated) read.
  void Read(int first_row, int rows, float* out);

 private:
  struct Input;
  std::filesystem::path file_;
  ImageHeader header_;
  std::unique_ptr<Input> input_;
};

}  // namespace mesocap::core
