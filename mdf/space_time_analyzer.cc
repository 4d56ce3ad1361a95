#include "mdf/space_time_analyzer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "calibration/laser_line.h"
#include "core/atomic_file.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "formats/sweep_analysis.h"

namespace mesocap::mdf {

core::CheckResult SpaceTimeOptions::Check() const {
  if (!(threshold > 0 && threshold < 1)) return "threshold must be in (0, 1)";
  if (!(saturation > threshold && saturation <= 1)) return "saturation must be in (threshold, 1]";
  if (min_peak_separation < 2) return "min_peak_separation must be at least 2 frames";
  return {};
}

SpaceTimeAnalyzer::SpaceTimeAnalyzer(int width, int height, int frame_count, SpaceTimeOptions options)
    : width_(width), height_(height), frame_count_(frame_count), options_(options) {
  if (width <= 0 || height <= 0 || frame_count <= 0) {
    throw core::Error("space-time analysis: image size and frame count must be positive");
  }
  core::ThrowIfInvalid(options.Check(), "space-time analysis");
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
  second_.assign(n, 0.5f * options_.threshold);
  second_index_.assign(n, -1);
  second_before_.assign(n, 0.0f);
  second_after_.assign(n, 0.0f);
  second_before_index_.assign(n, -1);
  second_after_index_.assign(n, -1);
  gate_.assign(n, 0.5f * options_.threshold);
  recent_maxima_.resize(options_.min_peak_separation);
}

void SpaceTimeAnalyzer::AddFrame(int index, const core::Image& frame) {
  if (frame.width() != width_ || frame.height() != height_ || frame.channels() != 1) {
    throw core::Error("space-time analysis: frame " + std::to_string(index) + " is " + std::to_string(frame.width()) +
                      "x" + std::to_string(frame.height()) + "x" + std::to_string(frame.channels()) + ", expected " +
                      std::to_string(width_) + "x" + std::to_string(height_) + "x1");
  }
  if (index <= last_index_ || index >= frame_count_) {
    throw core::Error("space-time analysis: frame index " + std::to_string(index) + " after " +
                      std::to_string(last_index_) + " (frames must increase, below " + std::to_string(frame_count_) +
                      ")");
  }
  const float* values = frame.data();
  const float saturation = options_.saturation;
  const int previous = last_index_;
  const std::size_t n = best_.size();
  float* best = best_.data();
  float* second = second_.data();
  float* last = last_.data();
  const int separation = options_.min_peak_separation;
  // The frame after each maximum: only the pixels listed as having taken a
  // new maximum in the previous frame (the stripe's rising edge), so the
  // common pixel never reads its maximum's frame index.
  if (previous >= 0 && recent_maxima_[previous % separation].frame == previous) {
    for (const std::uint32_t p : recent_maxima_[previous % separation].pixels) {
      after_[p] = values[p];
      after_index_[p] = index;
    }
  }
  for (const std::uint32_t p : new_second_) {
    second_after_[p] = values[p];
    second_after_index_[p] = index;
  }
  new_second_.clear();
  const float floor = 0.5f * options_.threshold;
  const float threshold = options_.threshold;
  float* gate = gate_.data();
  // Maxima now min_peak_separation frames old or more: from here on a value
  // above the pixel's second peak is a candidate, so its gate drops to it
  // (never above the maximum: a dark pixel's maxima are still tracked).
  for (RecentMaxima& slot : recent_maxima_) {
    if (slot.frame < 0 || index - slot.frame < separation) continue;
    for (const std::uint32_t p : slot.pixels) {
      if (best_index_[p] == slot.frame) gate[p] = std::min(best[p], std::max(second[p], threshold));
    }
    slot.pixels.clear();
    slot.frame = -1;
  }
  RecentMaxima& recent = recent_maxima_[index % separation];
  recent.frame = index;
  // Blocks of pixels with no value above their gate and none saturated (the
  // common case: the stripe covers few pixels of a frame) only record the
  // latest value; the test over a block vectorizes. The gate is the maximum
  // until that is min_peak_separation frames old (no value in between can
  // change the maximum or the second peak), then the second peak counted at
  // no less than the threshold (one below it is never reported), so the
  // stripe's falling flank and a lit pixel's read noise stay on this path.
  constexpr std::size_t kBlock = 32;
  for (std::size_t b = 0; b < n; b += kBlock) {
    const std::size_t end = std::min(n, b + kBlock);
    int eventful = 0;
    for (std::size_t p = b; p < end; ++p) {
      eventful |= static_cast<int>(values[p] > gate[p]) | static_cast<int>(values[p] >= saturation);
    }
    if (!eventful) [[likely]] {
      std::copy(values + b, values + end, last + b);
      continue;
    }
    for (std::size_t p = b; p < end; ++p) {
      const float v = values[p];
      if (v > best[p]) {
        const int old = best_index_[p];
        if (old >= 0 && index - old >= separation) {
          // The maximum so far was a peak of its own: it becomes the second.
          second[p] = best[p];
          second_index_[p] = old;
          second_before_[p] = before_[p];
          second_before_index_[p] = before_index_[p];
          second_after_[p] = after_[p];
          second_after_index_[p] = after_index_[p];
        } else if (second_index_[p] >= 0 && index - second_index_[p] < separation) {
          // The second peak was the rising flank of this one.
          second[p] = floor;
          second_index_[p] = -1;
        }
        best[p] = v;
        best_index_[p] = index;
        before_[p] = last[p];
        before_index_[p] = previous;
        after_index_[p] = -1;
        gate[p] = v;
        recent.pixels.push_back(static_cast<std::uint32_t>(p));
      } else if (v > gate[p] && v < saturation && index - best_index_[p] >= separation) {
        // The brightest value far enough from the maximum, whether or not
        // it is a local maximum: a dim far surface on the tail of the first
        // peak is a shoulder, not a peak (requiring a rising value: texels
        // off by more than a texel 5.16 % -> 5.63 %). Resampling keeps only
        // the second points that continue a neighbour's surface.
        second[p] = v;
        second_index_[p] = index;
        second_before_[p] = last[p];
        second_before_index_[p] = previous;
        second_after_index_[p] = -1;
        new_second_.push_back(static_cast<std::uint32_t>(p));
        gate[p] = v;
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

formats::SweepAnalysis SpaceTimeAnalyzer::Result() const {
  formats::SweepAnalysis result;
  result.width = width_;
  result.height = height_;
  result.frame_count = frame_count_;
  const std::size_t n = best_.size();
  result.peak_time.assign(n, std::numeric_limits<float>::quiet_NaN());
  result.peak_value.assign(n, 0.0f);
  result.second_time.assign(n, std::numeric_limits<float>::quiet_NaN());
  result.second_value.assign(n, 0.0f);
  result.planes.resize(frame_count_);
  // A peak's sub-frame time from the frames delivered around it (its own
  // frame where one of them is missing: the first or last frame).
  auto vertex = [](int before_index, float before, int index, float value, int after_index, float after) {
    if (before_index < 0 || after_index < 0) return static_cast<float>(index);
    return static_cast<float>(calibration::InterpolatePeak(before_index, before, index, value, after_index, after));
  };
  for (std::size_t p = 0; p < n; ++p) {
    if (second_index_[p] >= 0 && second_[p] >= options_.threshold) {
      result.second_value[p] = second_[p];
      result.second_time[p] = vertex(second_before_index_[p], second_before_[p], second_index_[p], second_[p],
                                     second_after_index_[p], second_after_[p]);
    }
    result.peak_value[p] = best_index_[p] >= 0 ? best_[p] : 0.0f;
    if (best_[p] < options_.threshold) continue;
    if (best_[p] >= options_.saturation && saturated_first_[p] >= 0) {
      result.peak_time[p] = static_cast<float>(0.5 * (saturated_first_[p] + saturated_last_[p]));
    } else {
      result.peak_time[p] = vertex(before_index_[p], before_[p], best_index_[p], best_[p], after_index_[p], after_[p]);
    }
  }
  return result;
}

}  // namespace mesocap::mdf
