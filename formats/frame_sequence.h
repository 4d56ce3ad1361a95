// An image sequence in one file: the frames a camera records while the laser
// stripe sweeps across the sample (MDF paper Sec. 3.2, the sequence
// {I_v,l(x, y, t_i)}). Stored as a multi-subimage TIFF, one subimage per
// frame, deflate-compressed, so ordinary tools can open it.
//
// Both sides stream: the writer appends frames one by one and the reader
// yields one frame at a time, so neither ever holds a whole sweep (a paper
// sized sweep is hundreds of megapixel frames).
#pragma once

#include <filesystem>
#include <memory>

#include "core/atomic_file.h"
#include "core/image.h"
#include "core/image_io.h"

namespace mesocap::formats {

struct FrameSequenceHeader {
  int width = 0;
  int height = 0;
  int channels = 0;
  core::PixelEncoding encoding = core::PixelEncoding::kUInt16;
  int frame_count = 0;
};

// Writes frames to a temporary file next to `file`; Commit() renames it into
// place (core/atomic_file.h), so a crash mid-sweep leaves no partial file.
// Destroyed without Commit(), the partial file is removed.
class FrameSequenceWriter {
 public:
  // .tif / .tiff only; encoding kUInt8, kUInt16 or kFloat32 (integer
  // encodings map [0, 1] to the full code range, as WriteImage does).
  FrameSequenceWriter(std::filesystem::path file, int width, int height, int channels,
                      core::PixelEncoding encoding = core::PixelEncoding::kUInt16);
  ~FrameSequenceWriter();
  FrameSequenceWriter(const FrameSequenceWriter&) = delete;
  FrameSequenceWriter& operator=(const FrameSequenceWriter&) = delete;

  // Throws Error when the frame's size or channel count differs from the
  // sequence's, or the write fails.
  void Append(const core::Image& frame);
  int frame_count() const { return frame_count_; }
  // Closes and renames into place. Throws Error on a sequence without frames.
  void Commit();

 private:
  struct Output;
  std::filesystem::path file_;
  core::AtomicFile atomic_;
  FrameSequenceHeader header_;
  std::unique_ptr<Output> output_;
  int frame_count_ = 0;
  bool committed_ = false;
};

// Reads a sequence frame by frame. Opening validates every frame's header
// (same size, channels and pixel type; a bounded frame count), so a reader
// learns of a bad file before it reads pixels. Errors are FormatError naming
// the file and the field ("frame 3: width").
class FrameSequenceReader {
 public:
  // At most max_frames frames and max_values = width * height * channels per
  // frame are accepted.
  explicit FrameSequenceReader(std::filesystem::path file, int max_frames = 1 << 20,
                               std::size_t max_values = std::size_t{1} << 28);
  ~FrameSequenceReader();
  FrameSequenceReader(const FrameSequenceReader&) = delete;
  FrameSequenceReader& operator=(const FrameSequenceReader&) = delete;

  const FrameSequenceHeader& header() const { return header_; }
  // The next frame as float in [0, 1] (integer encodings), or false after
  // the last one.
  bool Next(core::Image* frame);
  int next_index() const { return next_; }

 private:
  struct Input;
  std::filesystem::path file_;
  FrameSequenceHeader header_;
  std::unique_ptr<Input> input_;
  int next_ = 0;
};

// Reads the header (with the frame count) only.
FrameSequenceHeader ReadFrameSequenceHeader(const std::filesystem::path& file);

}  // namespace mesocap::formats
