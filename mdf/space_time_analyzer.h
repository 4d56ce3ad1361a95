// Space-time analysis (MDF paper Sec. 3.2, Fig. 5b, after Curless and Levoy
// 1995): for every pixel, the time at which the sweeping stripe is brightest
// there, interpolated between frames, and that brightness; below a threshold
// the pixel saw no stripe (occluded from the laser or the camera: "unknown").
//
// Streaming: frames are fed one at a time as they arrive (the capture daemon
// and the offline path call the same code) and each pixel keeps O(1) state,
// so no sequence is ever held in memory. The result (SweepAnalysis) is small
// (four floats per pixel plus one plane per frame), so a session can keep it
// instead of the raw frames.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "core/error.h"
#include "core/image.h"
#include "formats/sweep_analysis.h"

namespace mesocap::mdf {

struct SpaceTimeOptions {
  // Peak brightness below this (fraction of full scale) is "unknown". The
  // stripe peaks at 0.4-0.9 on the simulated rigs on surfaces facing the
  // laser, but at 0.005-0.05 where it grazes a round thread; the shipped
  // rigs' 12-bit cameras (5-8 e- read noise of 20000) keep a dark pixel
  // under 0.001, so 0.005 is 20 codes. An 8-bit or noisier camera needs more
  // (one 8-bit code is 0.004): `process mdf --threshold`.
  float threshold = 0.005f;
  // Values at or above this are saturated: the peak time is the middle of
  // the longest saturated run (a clipped profile has no vertex to fit).
  float saturation = 0.999f;
  // The second peak (below) is the brightest unsaturated value at least
  // this many frames from the first: the shipped rigs' stripe profiles have a
  // sigma of 1.1-1.9 frames, so a second surface closer in time than this
  // merges with the first (measured on weave, small rig: 3, 4, 6 and 8
  // frames place edges no better than 5).
  int min_peak_separation = 5;

  core::CheckResult Check() const;
};

class SpaceTimeAnalyzer {
 public:
  // Throws Error on a non-positive size or frame count, or bad options.
  SpaceTimeAnalyzer(int width, int height, int frame_count, SpaceTimeOptions options = {});

  // Frame `index` of the sweep (1 channel, the analyzer's size). Indices must
  // increase; a skipped index is a dropped frame: its neighbours' peaks are
  // interpolated over the real time gap. Throws Error otherwise.
  void AddFrame(int index, const core::Image& frame);
  int frames_added() const { return frames_added_; }

  // The per-pixel result so far (planes left empty for the caller to fill).
  formats::SweepAnalysis Result() const;

 private:
  // Per pixel, whatever the sweep length (structure of arrays): the arrays
  // every frame touches (the gate below, the latest value)
  // apart from those only a new maximum, the frame after it or a saturated
  // value touch, so the common pixel reads its value and 8 bytes of state
  // and writes 4. The pixels with a new maximum in each recent frame are
  // listed (few: the stripe's rising edge), for their next frame's value
  // and their gate (below).
  std::vector<float> best_;
  std::vector<std::int32_t> best_index_;
  std::vector<float> last_;
  std::vector<float> before_, after_;  // the frames around the maximum
  std::vector<std::int32_t> before_index_, after_index_;
  std::vector<std::int32_t> run_start_;                         // current saturated run
  std::vector<std::int32_t> saturated_first_, saturated_last_;  // longest saturated run
  // The second peak: the brightest value at least min_peak_separation
  // frames from the maximum, with its neighbouring frames, and the pixels
  // whose second peak is the latest frame.
  std::vector<float> second_;
  std::vector<std::int32_t> second_index_;
  std::vector<float> second_before_, second_after_;
  std::vector<std::int32_t> second_before_index_, second_after_index_;
  std::vector<std::uint32_t> new_second_;
  // What a value must exceed to need the per-pixel update (as must a
  // saturated value): the maximum for min_peak_separation frames after it
  // was set, then min(maximum, max(second peak, threshold)). The pixels
  // that set a maximum in each of the last min_peak_separation frames.
  std::vector<float> gate_;
  struct RecentMaxima {
    int frame = -1;
    std::vector<std::uint32_t> pixels;
  };
  std::vector<RecentMaxima> recent_maxima_;
  int width_;
  int height_;
  int frame_count_;
  SpaceTimeOptions options_;
  int last_index_ = -1;
  int frames_added_ = 0;
};

}  // namespace mesocap::mdf
