// The MDF job (`mesocap process mdf`): the 4D MDF of a capture session's
// laser scans (MDF paper Sec. 3.2, computed by mdf::ProcessMdfSession),
// written in float and 8-bit form (Sec. 5) with its confidence and the
// calibration into a new material package.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/error.h"
#include "mdf/mdf_session.h"

namespace mesocap::pipelines {

struct ProcessMdfOptions {
  std::filesystem::path session;      // capture session folder
  std::filesystem::path calibration;  // rig calibration file; empty: the one the session names
  std::filesystem::path out;          // material package folder to write
  double d_max_mm = 0;                // slab depth of the package; 0: the deepest measured point
  bool replace = false;               // replace an existing package at `out`
  // Plan steps the session may lack (ids or shell patterns; "*": any), whose
  // scans are then left out; empty: the session must be complete.
  std::vector<std::string> allow_incomplete;
  mdf::MdfProcessingOptions processing;

  core::CheckResult Check() const;
};

struct ProcessMdfReport {
  int sweeps = 0;  // camera sequences analysed
  int texels_per_side = 0;
  int views = 0;
  int laser_planes = 0;                    // fitted from their plates
  double worst_plane_height_sigma_mm = 0;  // one sigma, at the sample centre
};

// Everything is computed before the package is written, so bad input leaves
// nothing at `out`. Throws Error ("process mdf: ...") for bad options or an
// existing `out` without `replace`; FormatError for bad session data.
ProcessMdfReport RunProcessMdf(const ProcessMdfOptions& options);

}  // namespace mesocap::pipelines
