#include "formats/frame_sequence.h"

#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <mutex>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_io.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
namespace {

OIIO::TypeDesc TypeOf(core::PixelEncoding e) {
  switch (e) {
    case core::PixelEncoding::kUInt8:
      return OIIO::TypeDesc::UINT8;
    case core::PixelEncoding::kUInt16:
      return OIIO::TypeDesc::UINT16;
    case core::PixelEncoding::kFloat32:
      return OIIO::TypeDesc::FLOAT;
    case core::PixelEncoding::kHalf:
      break;
  }
  return OIIO::TypeDesc::UNKNOWN;
}

bool IsTiff(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".tif" || ext == ".tiff";
}

// As in core/image_io.cc: a corrupt header that declares a huge image fails
// fast instead of allocating.
void LimitDeclaredImageSize() {
  static std::once_flag once;
  std::call_once(once, [] { OIIO::attribute("limits:imagesize_MB", 8192); });
}

std::string FrameField(int frame, const char* field) { return "frame " + std::to_string(frame) + ": " + field; }

}  // namespace

struct FrameSequenceWriter::Output {
  std::unique_ptr<OIIO::ImageOutput> out;
  OIIO::ImageSpec spec;
  std::vector<std::byte> encoded;  // one frame in the file's pixel type
};

FrameSequenceWriter::FrameSequenceWriter(fs::path file, int width, int height, int channels,
                                         core::PixelEncoding encoding)
    : file_(std::move(file)), atomic_(file_) {
  if (!IsTiff(file_)) throw core::Error(file_.string() + ": a frame sequence is a .tif or .tiff file");
  if (encoding == core::PixelEncoding::kHalf)
    throw core::Error(file_.string() + ": TIFF frame sequences cannot store half");
  if (width <= 0 || height <= 0 || channels < 1 || channels > 4) {
    throw core::Error(file_.string() + ": bad frame size " + std::to_string(width) + "x" + std::to_string(height) +
                      "x" + std::to_string(channels));
  }
  header_ = {width, height, channels, encoding, 0};
  output_ = std::make_unique<Output>();
  output_->out = OIIO::ImageOutput::create(file_.string());
  if (!output_->out)
    throw core::Error(file_.string() + ": no TIFF writer: " + core::ImageLibraryMessage(OIIO::geterror()));
  if (!output_->out->supports("appendsubimage")) {
    throw core::Error(file_.string() + ": the TIFF writer cannot append subimages");
  }
  output_->spec = OIIO::ImageSpec(width, height, channels, TypeOf(encoding));
  // TIFF deflate at its fastest level: a sweep frame is mostly read noise,
  // which level 6 packs 20 % tighter at five times the time, and a session
  // writes tens of thousands of frames.
  output_->spec.attribute("compression", "zip:1");
  output_->spec.attribute("oiio:UnassociatedAlpha", 1);
  output_->spec.attribute("DateTime", "");  // the same frames give the same bytes (core/image_io.cc)
}

FrameSequenceWriter::~FrameSequenceWriter() {
  // Without Commit the AtomicFile member removes the partial file; close the
  // writer first so nothing writes to it afterwards.
  if (output_ && output_->out && !committed_ && frame_count_ > 0) output_->out->close();
}

void FrameSequenceWriter::Append(const core::Image& frame) {
  if (committed_) throw core::Error(file_.string() + ": frame sequence already committed");
  if (frame.width() != header_.width || frame.height() != header_.height || frame.channels() != header_.channels) {
    throw core::Error(file_.string() + ": frame " + std::to_string(frame_count_) + " is " +
                      std::to_string(frame.width()) + "x" + std::to_string(frame.height()) + "x" +
                      std::to_string(frame.channels()) + ", the sequence is " + std::to_string(header_.width) + "x" +
                      std::to_string(header_.height) + "x" + std::to_string(header_.channels));
  }
  auto& out = *output_->out;
  // Converted here, on this thread: the TIFF writer would convert each
  // scanline on the library's thread pool, a hand-off per row that costs
  // more than the conversion. The same library routine, the same values.
  const OIIO::TypeDesc type = output_->spec.format;
  output_->encoded.resize(frame.size() * type.size());
  if (!OIIO::convert_image(frame.channels(), frame.width(), frame.height(), 1, frame.data(), OIIO::TypeDesc::FLOAT,
                           OIIO::AutoStride, OIIO::AutoStride, OIIO::AutoStride, output_->encoded.data(), type,
                           OIIO::AutoStride, OIIO::AutoStride, OIIO::AutoStride)) {
    throw core::Error(file_.string() + ": frame " + std::to_string(frame_count_) + " cannot be stored as " +
                      type.c_str());
  }
  const auto mode = frame_count_ == 0 ? OIIO::ImageOutput::Create : OIIO::ImageOutput::AppendSubimage;
  if (!out.open(atomic_.temp_path().string(), output_->spec, mode) || !out.write_image(type, output_->encoded.data())) {
    throw core::Error(file_.string() + ": writing frame " + std::to_string(frame_count_) +
                      " failed: " + core::ImageLibraryMessage(out.geterror()) + core::FullDiskNote(file_));
  }
  ++frame_count_;
  header_.frame_count = frame_count_;
}

void FrameSequenceWriter::Commit() {
  if (committed_) return;
  if (frame_count_ == 0) throw core::Error(file_.string() + ": refusing to write a frame sequence without frames");
  if (!output_->out->close()) {
    throw core::Error(file_.string() + ": closing failed: " + core::ImageLibraryMessage(output_->out->geterror()) +
                      core::FullDiskNote(file_));
  }
  atomic_.Commit();
  committed_ = true;
}

struct FrameSequenceReader::Input {
  std::unique_ptr<OIIO::ImageInput> in;
};

FrameSequenceReader::FrameSequenceReader(fs::path file, int max_frames, std::size_t max_values)
    : file_(std::move(file)), input_(std::make_unique<Input>()) {
  LimitDeclaredImageSize();
  std::error_code ec;
  if (!fs::is_regular_file(file_, ec)) throw core::FormatError(file_, "", "not found or not a regular file");
  if (!IsTiff(file_)) throw core::FormatError(file_, "", "a frame sequence is a .tif or .tiff file");
  input_->in = OIIO::ImageInput::open(file_.string());
  if (!input_->in)
    throw core::FormatError(file_, "", "not a readable TIFF: " + core::ImageDecodeFailure(file_, OIIO::geterror()));
  auto& in = *input_->in;
  // Every frame's header up front (headers only, no pixels): the sequence is
  // uniform or it is rejected before anyone reads it.
  for (int f = 0; in.seek_subimage(f, 0); ++f) {
    if (f >= max_frames) {
      throw core::FormatError(file_, "frames", "more than the limit of " + std::to_string(max_frames));
    }
    const OIIO::ImageSpec& spec = in.spec();
    if (f == 0) {
      if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1) {
        throw core::FormatError(file_, FrameField(f, "size"), "expected a positive 2D size");
      }
      if (spec.nchannels < 1 || spec.nchannels > 4) {
        throw core::FormatError(file_, FrameField(f, "channels"), "expected 1 to 4");
      }
      if (spec.format == OIIO::TypeDesc::UINT8) {
        header_.encoding = core::PixelEncoding::kUInt8;
      } else if (spec.format == OIIO::TypeDesc::UINT16) {
        header_.encoding = core::PixelEncoding::kUInt16;
      } else if (spec.format == OIIO::TypeDesc::FLOAT) {
        header_.encoding = core::PixelEncoding::kFloat32;
      } else {
        throw core::FormatError(file_, FrameField(f, "pixel type"),
                                std::string("expected uint8, uint16 or float, got ") + spec.format.c_str());
      }
      header_.width = spec.width;
      header_.height = spec.height;
      header_.channels = spec.nchannels;
      const std::size_t values = static_cast<std::size_t>(spec.width) * spec.height * spec.nchannels;
      if (values > max_values) {
        throw core::FormatError(file_, FrameField(f, "size"),
                                "exceeds the limit of " + std::to_string(max_values) + " values per frame");
      }
    } else {
      if (spec.width != header_.width) throw core::FormatError(file_, FrameField(f, "width"), "differs from frame 0");
      if (spec.height != header_.height)
        throw core::FormatError(file_, FrameField(f, "height"), "differs from frame 0");
      if (spec.nchannels != header_.channels) {
        throw core::FormatError(file_, FrameField(f, "channels"), "differs from frame 0");
      }
      if (spec.format != TypeOf(header_.encoding)) {
        throw core::FormatError(file_, FrameField(f, "pixel type"), "differs from frame 0");
      }
    }
    header_.frame_count = f + 1;
  }
  if (header_.frame_count == 0) throw core::FormatError(file_, "frames", "no frames");
  // The failed seek past the last frame leaves the reader without a current
  // frame and with a pending error message (geterror() clears it); go back
  // to the first frame.
  (void)in.geterror();
  if (!in.seek_subimage(0, 0))
    throw core::FormatError(file_, FrameField(0, "header"),
                            "cannot seek: " + core::ImageDecodeFailure(file_, in.geterror()));
}

FrameSequenceReader::~FrameSequenceReader() {
  if (input_ && input_->in) input_->in->close();
}

bool FrameSequenceReader::Next(core::Image* frame) {
  if (next_ >= header_.frame_count) return false;
  auto& in = *input_->in;
  core::Image image(header_.width, header_.height, header_.channels);
  if (!in.seek_subimage(next_, 0) ||
      !in.read_image(next_, 0, 0, header_.channels, OIIO::TypeDesc::FLOAT, image.data()) || in.has_error()) {
    throw core::FormatError(file_, FrameField(next_, "pixels"),
                            "cannot read: " + core::ImageDecodeFailure(file_, in.geterror()));
  }
  *frame = std::move(image);
  ++next_;
  return true;
}

FrameSequenceHeader ReadFrameSequenceHeader(const fs::path& file) { return FrameSequenceReader(file).header(); }

}  // namespace mesocap::formats
