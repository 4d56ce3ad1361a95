// Test harness: a laser scan of a simulated scene fed frame by frame from
// the simulated rig's renderer straight into the processing code (no disk:
// a small-rig session is ~1 GB), with the exact MDF to compare against.
#pragma once

#include <functional>
#include <set>
#include <string>
#include <vector>

#include "calibration/laser_line.h"
#include "core/image.h"
#include "core/mdf.h"
#include "mdf/displacement_merge.h"
#include "mdf/space_time_analyzer.h"

namespace mesocap::mdf {

struct ScanSetup {
  std::string scene = "blocks";
  std::string rig = "tiny";
  std::vector<int> turntable_indices;  // empty: all
  std::vector<int> cameras;            // empty: all
  std::vector<int> locations;          // empty: all
  int texture_size = 64;
  bool noise = true;
  double signal_gain = 1.0;      // multiplies the stripe before the sensor (saturation)
  std::set<int> dropped_frames;  // frame indices never delivered
  // Changes a frame's signal before the sensor: (frame index, signal).
  std::function<void(int, core::Image*)> tamper;
  calibration::LaserLineOptions line;
  SpaceTimeOptions space_time;
  TriangulationOptions triangulation;
  MergeOptions merge;
};

struct ScanResult {
  core::Mdf truth;
  core::Mdf estimate;
  core::Image confidence;
  double texel_mm = 0;
  // Time spent in the processing code (line detection, space-time analysis,
  // triangulation, resampling, merging), without rendering.
  double processing_seconds = 0;
};

ScanResult RunSimulatedScan(const ScanSetup& setup);

}  // namespace mesocap::mdf
