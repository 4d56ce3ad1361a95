// The 4D MDF from displacement images (MDF paper Sec. 3.2 and Sec. 5): each
// sweep's space-time result is triangulated and resampled to the texture
// grid of its view; once all sweeps are in, each view's images are merged
// with the paper's tetrahedron weights into D_v(x, y).
#pragma once

#include <vector>

#include "calibration/camera_rays.h"
#include "calibration/texel_grid.h"
#include "core/image.h"
#include "core/mdf.h"
#include "core/rigid_transform.h"
#include "core/sampling_set.h"
#include "formats/sweep_analysis.h"
#include "mdf/displacement_image.h"
#include "mdf/displacement_merge.h"
#include "mdf/space_time_analyzer.h"

namespace mesocap::mdf {

class MdfAssembler {
 public:
  // Throws Error on bad options or an empty view set.
  MdfAssembler(calibration::TexelGrid grid, core::SamplingSet views, TriangulationOptions triangulation,
               MergeOptions merge);

  // One sweep seen in `view` (an index into the view set) with scan weight
  // `weight` (> 0, ScanWeight). Sweeps may come in any order.
  void AddSweep(int view, const formats::SweepAnalysis& analysis, const calibration::CameraRays& rays,
                const core::RigidTransform& world_from_sample, double weight);
  // Adds an already resampled displacement image.
  void AddDisplacementImage(int view, DisplacementImage image, double weight);

  // The merged MDF (views without sweeps stay unknown) and, when asked, the
  // per-texel confidence in the same layout (1 channel).
  core::Mdf Finish(core::Image* confidence = nullptr) const;

  const calibration::TexelGrid& grid() const { return grid_; }
  const core::SamplingSet& views() const { return views_; }

 private:
  calibration::TexelGrid grid_;
  core::SamplingSet views_;
  TriangulationOptions triangulation_;
  MergeOptions merge_;
  std::vector<std::vector<DisplacementImage>> images_;  // per view
  std::vector<std::vector<double>> weights_;
};

}  // namespace mesocap::mdf
