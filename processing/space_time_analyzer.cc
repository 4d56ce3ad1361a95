#include "processing/space_time_analyzer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/atomic_file.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "processing/laser_line.h"

namespace mesocap {

CheckResult SpaceTimeOptions::Check() const {
  if (!(threshold > 0 && threshold < 1)) return "threshold must be in (0, 1)";
  if (!(saturation > threshold && saturation <= 1)) return "saturation must be in (threshold, 1]";
  return {};
}

SpaceTimeAnalyzer::SpaceTimeAnalyzer(int width, int height, int frame_count, SpaceTimeOptions options)
    : width_(width), height_(height), frame_count_(frame_count), options_(options) {
  if (width <= 0 || height <= 0 || frame_count <= 0) {
    throw Error("space-time analysis: image size and frame count must be positive");
  }
  if (const auto problem = options.Check(); !problem.empty()) throw Error("space-time analysis: " + problem);
  const std::size_t n = static_cast<std::size_t>(width) * height;
  // Maxima below half the threshold are never tracked: the pixel is unknown
  // whatever they were, and the sensor noise of dark pixels, which keeps
  // setting new maxima early in a sweep, then takes the fast path. A peak
  // at or above the threshold is found exactly as without the floor.
  best_.assign(n, 0.5f * options_.threshold);
  best_index_.assign(n, -1);
  last_.assign(n, 0.0f);
  before_.assign(n, 0.0f);
  after_.assign(n, 0.0f);
  before_index_.assign(n, -1);
  after_index_.assign(n, -1);
  run_start_.assign(n, -1);
  saturated_first_.assign(n, -1);
  saturated_last_.assign(n, -1);
}

void SpaceTimeAnalyzer::AddFrame(int index, const Image& frame) {
  if (frame.width() != width_ || frame.height() != height_ || frame.channels() != 1) {
    throw Error("space-time analysis: frame " + std::to_string(index) + " is " + std::to_string(frame.width()) +
                "x" + std::to_string(frame.height()) + "x" + std::to_string(frame.channels()) + ", expected " +
                std::to_string(width_) + "x" + std::to_string(height_) + "x1");
  }
  if (index <= last_index_ || index >= frame_count_) {
    throw Error("space-time analysis: frame index " + std::to_string(index) + " after " +
                std::to_string(last_index_) + " (frames must increase, below " + std::to_string(frame_count_) + ")");
  }
  const float* values = frame.data();
  const float saturation = options_.saturation;
  const int previous = last_index_;
  const std::size_t n = best_.size();
  float* best = best_.data();
  float* last = last_.data();
  // The frame after each maximum: only the pixels listed as having taken a
  // new maximum in the previous frame (the stripe's rising edge), so the
  // common pixel never reads its maximum's frame index.
  for (const std::uint32_t p : new_maximum_) {
    after_[p] = values[p];
    after_index_[p] = index;
  }
  new_maximum_.clear();
  // Blocks of pixels with neither a new maximum nor a saturated value (the
  // common case: the stripe covers few pixels of a frame) only record the
  // latest value; the test over a block vectorizes.
  constexpr std::size_t kBlock = 32;
  for (std::size_t b = 0; b < n; b += kBlock) {
    const std::size_t end = std::min(n, b + kBlock);
    int eventful = 0;
    for (std::size_t p = b; p < end; ++p) {
      eventful |= static_cast<int>(values[p] > best[p]) | static_cast<int>(values[p] >= saturation);
    }
    if (!eventful) [[likely]] {
      std::copy(values + b, values + end, last + b);
      continue;
    }
    for (std::size_t p = b; p < end; ++p) {
      const float v = values[p];
      if (v > best[p]) {
        best[p] = v;
        best_index_[p] = index;
        before_[p] = last[p];
        before_index_[p] = previous;
        after_index_[p] = -1;
        new_maximum_.push_back(static_cast<std::uint32_t>(p));
      }
      if (v >= saturation) {
        // A run continues when the previous frame was saturated too.
        if (!(last[p] >= saturation) || previous < 0) run_start_[p] = index;
        if (saturated_first_[p] < 0 || index - run_start_[p] > saturated_last_[p] - saturated_first_[p]) {
          saturated_first_[p] = run_start_[p];
          saturated_last_[p] = index;
        }
      }
      last[p] = v;
    }
  }
  last_index_ = index;
  ++frames_added_;
}

SweepAnalysis SpaceTimeAnalyzer::Result() const {
  SweepAnalysis result;
  result.width = width_;
  result.height = height_;
  result.frame_count = frame_count_;
  const std::size_t n = best_.size();
  result.peak_time.assign(n, std::numeric_limits<float>::quiet_NaN());
  result.peak_value.assign(n, 0.0f);
  result.planes.resize(frame_count_);
  for (std::size_t p = 0; p < n; ++p) {
    result.peak_value[p] = best_index_[p] >= 0 ? best_[p] : 0.0f;
    if (best_[p] < options_.threshold) continue;
    double t = best_index_[p];
    if (best_[p] >= options_.saturation && saturated_first_[p] >= 0) {
      t = 0.5 * (saturated_first_[p] + saturated_last_[p]);
    } else if (before_index_[p] >= 0 && after_index_[p] >= 0) {
      t = InterpolatePeak(before_index_[p], before_[p], best_index_[p], best_[p], after_index_[p], after_[p]);
    }
    result.peak_time[p] = static_cast<float>(t);
  }
  return result;
}

namespace {

std::filesystem::path ImageFile(const std::filesystem::path& file) {
  std::filesystem::path image = file;
  image += ".exr";
  return image;
}

}  // namespace

void WriteSweepAnalysis(const std::filesystem::path& file, const SweepAnalysis& analysis) {
  const std::size_t n = static_cast<std::size_t>(analysis.width) * analysis.height;
  if (analysis.peak_time.size() != n || analysis.peak_value.size() != n ||
      analysis.planes.size() != static_cast<std::size_t>(analysis.frame_count)) {
    throw Error("sweep analysis " + file.string() + ": sizes do not match width, height and frame_count");
  }
  Image image(analysis.width, analysis.height, 2);
  for (std::size_t p = 0; p < n; ++p) {
    image.data()[2 * p] = analysis.peak_time[p];
    image.data()[2 * p + 1] = analysis.peak_value[p];
  }
  WriteImage(ImageFile(file), image, PixelEncoding::kFloat32);
  nlohmann::json planes = nlohmann::json::array();
  for (const Plane& plane : analysis.planes) planes.push_back(ToJson(plane));
  WriteJsonFileAtomically(file, {{"format", "mesocap.sweep_analysis"},
                                 {"version", 1},
                                 {"width", analysis.width},
                                 {"height", analysis.height},
                                 {"frame_count", analysis.frame_count},
                                 {"image", ImageFile(file).filename().string()},
                                 {"planes", planes}});
}

SweepAnalysis ReadSweepAnalysis(const std::filesystem::path& file) {
  const nlohmann::json doc = ReadJsonFile(file, 64ull << 20);
  auto integer = [&](const char* field, int max) {
    if (!doc.is_object() || !doc.contains(field) || !doc[field].is_number_integer() || doc[field].get<long long>() < 1 ||
        doc[field].get<long long>() > max) {
      throw FormatError(file, field, "an integer in 1.." + std::to_string(max));
    }
    return doc[field].get<int>();
  };
  if (!doc.is_object() || doc.value("format", std::string()) != "mesocap.sweep_analysis") {
    throw FormatError(file, "format", "\"mesocap.sweep_analysis\"");
  }
  if (doc.value("version", 0) != 1) throw FormatError(file, "version", "1");
  SweepAnalysis analysis;
  analysis.width = integer("width", 1 << 15);
  analysis.height = integer("height", 1 << 15);
  analysis.frame_count = integer("frame_count", 1 << 20);
  if (!doc.contains("planes") || !doc["planes"].is_array() ||
      doc["planes"].size() != static_cast<std::size_t>(analysis.frame_count)) {
    throw FormatError(file, "planes", "an array of frame_count planes");
  }
  for (std::size_t i = 0; i < doc["planes"].size(); ++i) {
    analysis.planes.push_back(PlaneFromJson(doc["planes"][i], file, "planes[" + std::to_string(i) + "]"));
  }
  ImageReadOptions options;
  options.expected_width = analysis.width;
  options.expected_height = analysis.height;
  options.expected_channels = 2;
  const Image image = ReadImage(ImageFile(file), options);
  const std::size_t n = static_cast<std::size_t>(analysis.width) * analysis.height;
  analysis.peak_time.resize(n);
  analysis.peak_value.resize(n);
  for (std::size_t p = 0; p < n; ++p) {
    const float t = image.data()[2 * p];
    if (!std::isnan(t) && !(t >= 0 && t <= analysis.frame_count - 1)) {
      throw FormatError(ImageFile(file), "peak time", "NaN or a frame time in [0, frame_count - 1]");
    }
    analysis.peak_time[p] = t;
    analysis.peak_value[p] = image.data()[2 * p + 1];
  }
  return analysis;
}

}  // namespace mesocap
