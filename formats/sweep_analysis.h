// The space-time analysis of one sweep (MDF paper Sec. 3.2, Fig. 5b) as a
// value and as a file: a session of a rig with "sweep_storage": "analysis"
// keeps these instead of the raw frames.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/plane.h"

namespace mesocap::formats {

// The analysis of one sweep of one camera: per pixel (row-major) the peak
// time in frames (NaN where unknown) and the peak value (0 where it never
// exceeded half the threshold), plus each frame's
// laser plane (invalid where no stripe line was found or the frame was
// dropped).
//
// The second peak is the stripe crossing a second surface inside the same
// pixel: a pixel straddling an occluding edge sees the near surface and,
// later or earlier in the sweep, the far one. Its time and value (NaN and 0
// where none reached the threshold) let resampling place the edge inside
// the pixel instead of giving the whole pixel to the brighter surface. A
// second peak may also be an interreflection ghost: resampling decides
// whether its point continues a neighbour's surface.
struct SweepAnalysis {
  int width = 0;
  int height = 0;
  int frame_count = 0;
  std::vector<float> peak_time;
  std::vector<float> peak_value;
  std::vector<float> second_time;
  std::vector<float> second_value;
  std::vector<core::Plane> planes;  // frame_count
};

// A sweep analysis on disk: <file> (JSON: sizes, planes) beside <file>.exr
// (4 channels: peak time, peak value, second peak time, second peak value;
// version 1 files have the first two only and read with no second peaks).
// Both written atomically, the EXR first, so the JSON only ever names a
// complete image.
void WriteSweepAnalysis(const std::filesystem::path& file, const SweepAnalysis& analysis);
// The image file beside a sweep analysis "laser/x.sweep.json": "laser/x.sweep.json.exr".
std::string SweepAnalysisImagePath(const std::string& path);
// Throws FormatError naming the file and field on anything malformed.
SweepAnalysis ReadSweepAnalysis(const std::filesystem::path& file);

}  // namespace mesocap::formats
