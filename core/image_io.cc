#include "core/image_io.h"

#include <OpenImageIO/color.h>
#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <mutex>
#include <new>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"

namespace mesocap::core {
namespace fs = std::filesystem;
namespace {

enum class Container { kExr, kJpeg, kPng, kTiff };

Container ContainerOf(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".exr") return Container::kExr;
  if (ext == ".jpg" || ext == ".jpeg") return Container::kJpeg;
  if (ext == ".png") return Container::kPng;
  if (ext == ".tif" || ext == ".tiff") return Container::kTiff;
  throw Error(file.string() + ": unsupported image extension " + Quoted(ext) +
              "; expected .exr, .jpg, .jpeg, .png, .tif or .tiff");
}

OIIO::TypeDesc TypeOf(PixelEncoding e) {
  switch (e) {
    case PixelEncoding::kFloat32:
      return OIIO::TypeDesc::FLOAT;
    case PixelEncoding::kHalf:
      return OIIO::TypeDesc::HALF;
    case PixelEncoding::kUInt8:
      return OIIO::TypeDesc::UINT8;
    case PixelEncoding::kUInt16:
      return OIIO::TypeDesc::UINT16;
  }
  return OIIO::TypeDesc::FLOAT;
}

PixelEncoding EncodingOf(const fs::path& file, OIIO::TypeDesc t) {
  if (t == OIIO::TypeDesc::FLOAT) return PixelEncoding::kFloat32;
  if (t == OIIO::TypeDesc::HALF) return PixelEncoding::kHalf;
  if (t == OIIO::TypeDesc::UINT8) return PixelEncoding::kUInt8;
  if (t == OIIO::TypeDesc::UINT16) return PixelEncoding::kUInt16;
  throw FormatError(file, "pixel type", std::string("expected float, half, uint8 or uint16, got ") + t.c_str());
}

bool Supports(Container c, PixelEncoding e) {
  switch (c) {
    case Container::kExr:
      return e == PixelEncoding::kFloat32 || e == PixelEncoding::kHalf;
    case Container::kJpeg:
      return e == PixelEncoding::kUInt8;
    case Container::kPng:
      return e == PixelEncoding::kUInt8 || e == PixelEncoding::kUInt16;
    case Container::kTiff:
      return e != PixelEncoding::kHalf;
  }
  return false;
}

// OpenImageIO refuses images whose header declares more pixel data than
// this; a corrupt or hostile header then fails fast instead of allocating.
// 8 GB is far above any image mesocap writes, and above ReadImage's own
// default limit (ImageReadOptions::max_values).
void LimitDeclaredImageSize() {
  static std::once_flag once;
  std::call_once(once, [] { OIIO::attribute("limits:imagesize_MB", 8192); });
}

std::unique_ptr<OIIO::ImageInput> OpenInput(const fs::path& file) {
  LimitDeclaredImageSize();
  std::error_code ec;
  if (!fs::exists(file, ec)) throw FormatError(file, "", "file not found");
  if (!fs::is_regular_file(file, ec)) throw FormatError(file, "", "not a regular file");
  ContainerOf(file);
  // A 4th channel is data to mesocap, not alpha: never (un)premultiply it.
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  std::unique_ptr<OIIO::ImageInput> in;
  try {
    in = OIIO::ImageInput::open(file.string(), &config);
  } catch (const std::bad_alloc&) {
    throw FormatError(file, "size", "the header declares a size that cannot be allocated (corrupt file?)");
  }
  if (!in) throw FormatError(file, "", "not a readable image: " + ImageDecodeFailure(file, OIIO::geterror()));
  return in;
}

// The EXIF orientation (1: rows top to bottom, columns left to right, as
// stored; 2 to 8: mirrored and/or turned by 90-degree steps, as phones and
// cameras write a photo taken upright or on its side).
int OrientationOf(const fs::path& file, const OIIO::ImageSpec& spec) {
  const int orientation = spec.get_int_attribute("Orientation", 1);
  if (orientation < 1 || orientation > 8) {
    throw FormatError(file, "Orientation", "expected an EXIF orientation 1 to 8, got " + std::to_string(orientation));
  }
  return orientation;
}

// The size as displayed: orientations 5 to 8 turn the stored image by 90 degrees.
ImageHeader HeaderOf(const fs::path& file, const OIIO::ImageSpec& spec) {
  const bool turned = OrientationOf(file, spec) >= 5;
  if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1) {
    throw FormatError(
        file, "size",
        "expected a positive 2D size, got " + std::to_string(spec.width) + "x" + std::to_string(spec.height));
  }
  if (spec.nchannels < 1 || spec.nchannels > 4) {
    throw FormatError(file, "channels", "expected 1 to 4, got " + std::to_string(spec.nchannels));
  }
  return {turned ? spec.height : spec.width, turned ? spec.width : spec.height, spec.nchannels,
          EncodingOf(file, spec.format)};
}

void ExpectDimension(const fs::path& file, const char* field, int expected, int actual) {
  if (expected > 0 && expected != actual) {
    throw FormatError(file, field, "expected " + std::to_string(expected) + ", got " + std::to_string(actual));
  }
}

// The header of an open file, checked against what the caller expects.
ImageHeader ExpectedHeader(const fs::path& file, const OIIO::ImageInput& in, const ImageReadOptions& options) {
  const ImageHeader header = HeaderOf(file, in.spec());
  ExpectDimension(file, "width", options.expected_width, header.width);
  ExpectDimension(file, "height", options.expected_height, header.height);
  ExpectDimension(file, "channels", options.expected_channels, header.channels);
  if (options.expected_encoding && header.encoding != *options.expected_encoding) {
    throw FormatError(
        file, "pixel type",
        std::string("expected ") + ToString(*options.expected_encoding) + ", got " + ToString(header.encoding));
  }
  return header;
}

[[noreturn]] void ThrowReadFailure(const fs::path& file, OIIO::ImageInput& in) {
  throw FormatError(file, "pixels", "cannot read: " + ImageDecodeFailure(file, in.geterror()));
}

}  // namespace

std::string ImageLibraryMessage(const std::string& error) { return Cut(error.substr(0, error.find('\n'))); }

std::string ImageDecodeFailure(const fs::path& file, const std::string& library_error) {
  spdlog::debug("{}: the image library says: {}", file.string(), ImageLibraryMessage(library_error));
  std::string extension = file.extension().string();
  for (char& c : extension) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return "the file is damaged, cut short or not " +
         (extension.size() > 1 ? extension.substr(1) : std::string("an image")) +
         " (mesocap -v logs the decoder's own words)";
}

ImageHeader ReadImageHeader(const fs::path& file) {
  auto in = OpenInput(file);
  return HeaderOf(file, in->spec());
}

bool IsImageFile(const fs::path& file) {
  try {
    ReadImageHeader(file);
    return true;
  } catch (const Error&) {
    return false;
  }
}

Image ReadImage(const fs::path& file, const ImageReadOptions& options) {
  auto in = OpenInput(file);
  const ImageHeader header = ExpectedHeader(file, *in, options);
  const auto values = static_cast<std::size_t>(header.width) * static_cast<std::size_t>(header.height) *
                      static_cast<std::size_t>(header.channels);
  if (values > options.max_values) {
    throw FormatError(file, "size",
                      std::to_string(header.width) + "x" + std::to_string(header.height) + "x" +
                          std::to_string(header.channels) + " values exceed the limit of " +
                          std::to_string(options.max_values));
  }
  const OIIO::ImageSpec& spec = in->spec();
  Image stored(spec.width, spec.height, header.channels);
  const bool ok = in->read_image(0, 0, 0, header.channels, OIIO::TypeDesc::FLOAT, stored.data());
  if (!ok || in->has_error()) ThrowReadFailure(file, *in);
  const int orientation = OrientationOf(file, spec);
  in->close();
  if (orientation == 1) return stored;
  // Turned and mirrored as the EXIF orientation says, by the image library.
  OIIO::ImageBuf source(OIIO::ImageSpec(stored.width(), stored.height(), stored.channels(), OIIO::TypeDesc::FLOAT),
                        stored.data());
  source.specmod().attribute("Orientation", orientation);
  const OIIO::ImageBuf upright = OIIO::ImageBufAlgo::reorient(source);
  Image image(header.width, header.height, header.channels);
  if (upright.has_error() || upright.spec().width != header.width || upright.spec().height != header.height ||
      !upright.get_pixels(upright.roi(), OIIO::TypeDesc::FLOAT, image.data())) {
    throw FormatError(file, "Orientation",
                      "cannot apply EXIF orientation " + std::to_string(orientation) + ": " +
                          ImageDecodeFailure(file, upright.geterror()));
  }
  return image;
}

struct ImageRowReader::Input {
  std::unique_ptr<OIIO::ImageInput> in;
};

ImageRowReader::ImageRowReader(const fs::path& file, const ImageReadOptions& expected)
    : file_(file), input_(std::make_unique<Input>()) {
  input_->in = OpenInput(file);
  header_ = ExpectedHeader(file, *input_->in, expected);
  // Rows are read as stored: a turned or mirrored image would need all of it.
  if (const int orientation = OrientationOf(file, input_->in->spec()); orientation != 1) {
    throw FormatError(
        file, "Orientation",
        "expected 1 (rows as stored) for a read by rows, got EXIF orientation " + std::to_string(orientation));
  }
}

ImageRowReader::~ImageRowReader() = default;

void ImageRowReader::Read(int first_row, int rows, float* out) {
  if (first_row < 0 || rows < 0 || first_row > header_.height - rows) {
    throw FormatError(file_, "rows",
                      "rows " + std::to_string(first_row) + ".." + std::to_string(first_row + rows) +
                          " outside the image's " + std::to_string(header_.height));
  }
  if (rows == 0) return;
  OIIO::ImageInput& in = *input_->in;
  const bool ok =
      in.read_scanlines(0, 0, first_row, first_row + rows, 0, 0, header_.channels, OIIO::TypeDesc::FLOAT, out);
  if (!ok || in.has_error()) ThrowReadFailure(file_, in);
}

void WriteImage(const fs::path& file, const Image& image, PixelEncoding encoding) {
  if (image.empty()) throw Error(file.string() + ": refusing to write an empty image");
  const Container container = ContainerOf(file);
  if (!Supports(container, encoding)) {
    throw Error(file.string() + ": the " + file.extension().string() + " format cannot store " + ToString(encoding) +
                " pixels");
  }
  auto out = OIIO::ImageOutput::create(file.string());
  if (!out) throw Error(file.string() + ": no image writer: " + ImageLibraryMessage(OIIO::geterror()));
  OIIO::ImageSpec spec(image.width(), image.height(), image.channels(), TypeOf(encoding));
  if (container == Container::kExr) spec.attribute("compression", "zip");
  // zlib level 1: a noisy 16-bit 1024 x 768 RGB capture image writes 3x
  // faster than at the default 6, for 5 % more bytes (a paper-rig session
  // writes 9216 of them).
  if (container == Container::kPng) spec.attribute("png:compressionLevel", 1);
  spec.attribute("oiio:UnassociatedAlpha", 1);
  // No write time in the file (OpenImageIO's TIFF writer adds one unless
  // told otherwise): the same data give the same bytes and checksum.
  spec.attribute("DateTime", "");
  // Encoded in memory and written by a checked write: some of the image
  // library's writers (PNG) do not report a write that a full disk cut
  // short, and a truncated file would be committed as a good one.
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput memory(bytes);
  if (!out->supports("ioproxy") || !out->set_ioproxy(&memory)) {
    throw Error(file.string() + ": the " + file.extension().string() + " writer cannot encode in memory");
  }
  // Converted here, on this thread: the writers would hand the conversion
  // to the library's thread pool (the TIFF writer row by row), while the
  // callers already write images in parallel. The same library routine.
  std::vector<std::byte> encoded(image.size() * spec.format.size());
  if (!OIIO::convert_image(image.channels(), image.width(), image.height(), 1, image.data(), OIIO::TypeDesc::FLOAT,
                           OIIO::AutoStride, OIIO::AutoStride, OIIO::AutoStride, encoded.data(), spec.format,
                           OIIO::AutoStride, OIIO::AutoStride, OIIO::AutoStride)) {
    throw Error(file.string() + ": cannot convert the image to " + ToString(encoding));
  }
  if (!out->open(file.string(), spec) || !out->write_image(spec.format, encoded.data()) || !out->close()) {
    throw Error(file.string() + ": write failed: " + ImageLibraryMessage(out->geterror()));
  }
  WriteTextFileAtomically(file, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

Image ScaledToFit(const Image& image, int max_side) {
  if (image.empty()) throw Error("scaling an empty image");
  if (max_side < 1) throw Error("scaling an image to fit " + std::to_string(max_side) + " pixels");
  const int longest = std::max(image.width(), image.height());
  if (longest <= max_side) return image;
  const double scale = static_cast<double>(max_side) / longest;
  const int width = std::max(1, static_cast<int>(image.width() * scale + 0.5));
  const int height = std::max(1, static_cast<int>(image.height() * scale + 0.5));
  const OIIO::ImageBuf source(OIIO::ImageSpec(image.width(), image.height(), image.channels(), OIIO::TypeDesc::FLOAT),
                              const_cast<float*>(image.data()));
  Image scaled(width, height, image.channels());
  OIIO::ImageBuf target(OIIO::ImageSpec(width, height, image.channels(), OIIO::TypeDesc::FLOAT), scaled.data());
  if (!OIIO::ImageBufAlgo::resize(target, source)) {
    throw Error("scaling an image: " + ImageLibraryMessage(target.geterror()));
  }
  return scaled;
}

std::string EncodePreviewPng(const Image& image) {
  if (image.empty()) throw Error("encoding an empty image");
  std::vector<unsigned char> codes(image.size());
  for (std::size_t i = 0; i < image.size(); ++i) {
    const float v = OIIO::linear_to_sRGB(std::clamp(image.data()[i], 0.0f, 1.0f));
    codes[i] = static_cast<unsigned char>(std::lround(v * 255.0f));
  }
  std::vector<unsigned char> bytes;
  OIIO::Filesystem::IOVecOutput memory(bytes);
  auto out = OIIO::ImageOutput::create("preview.png");
  if (!out) throw Error("no PNG writer: " + ImageLibraryMessage(OIIO::geterror()));
  const OIIO::ImageSpec spec(image.width(), image.height(), image.channels(), OIIO::TypeDesc::UINT8);
  if (!out->set_ioproxy(&memory) || !out->open("preview.png", spec) ||
      !out->write_image(OIIO::TypeDesc::UINT8, codes.data()) || !out->close()) {
    throw Error("encoding a PNG preview: " + ImageLibraryMessage(out->geterror()));
  }
  return std::string(bytes.begin(), bytes.end());
}

}  // namespace mesocap::core
