// `mesocap process mdf`: the MDF of a recorded capture session (MDF paper
// Sec. 3.2): the laser-plane calibration frames give each laser location's
// plane, every laser sweep is streamed frame by frame through line detection
// and space-time analysis, and the displacement images are merged per view
// into the 4D MDF on the session rig's view directions.
#pragma once

#include <filesystem>
#include <vector>

#include "core/image.h"
#include "core/mdf.h"
#include "core/progress.h"
#include "core/sampling_set.h"
#include "formats/calibration.h"
#include "formats/captured_session.h"
#include "mdf/displacement_image.h"
#include "mdf/displacement_merge.h"
#include "mdf/session_sweeps.h"
#include "mdf/space_time_analyzer.h"

namespace mesocap::mdf {

struct MdfProcessingOptions {
  int texture_size = 64;  // texels per side (the ground truth's default)
  // The stripe line detection and the reference region (laser planes).
  SweepGeometryOptions geometry;
  SpaceTimeOptions space_time;
  TriangulationOptions triangulation;
  MergeOptions merge;
  // Laser locations to use (indices into the rig's list); empty: all.
  std::vector<int> locations;

  core::CheckResult Check() const;
};

struct MdfProcessingResult {
  core::Mdf mdf;
  core::Image confidence;  // per texel and view, MDF layout (MdfAssembler)
  double sample_size_mm = 0;
  core::SamplingSet light_directions;  // the session rig's, for the package's description
  double deepest_mm = 0;               // deepest measured point below the reference plane
  int sweeps = 0;                      // camera sequences analysed
  // Laser planes fitted from their plates (per location and camera), and the
  // largest one-sigma height error one of them gives at the sample centre.
  int laser_planes = 0;
  double worst_plane_height_sigma_mm = 0;
};

// Reads the scans of the session's done steps, each file checked against its
// journal record. Throws FormatError / Error naming
// the file and field for a missing calibration entry (a camera or laser
// mount of the session's rig), a sequence whose frame size or count does not
// match the calibration and plan, or a missing file; nothing is written.
MdfProcessingResult ProcessMdfSession(const formats::CapturedSession& session, const formats::Calibration& calibration,
                                      const MdfProcessingOptions& options,
                                      core::Progress::Style progress = core::Progress::Style::kAuto);

}  // namespace mesocap::mdf
