// The laser geometry of a capture session's sweeps (MDF paper Sec. 3.2):
// each laser location's plane, per camera, from its two calibration plates,
// and each sweep's reference region and per-frame tilts. `mesocap process
// mdf` and the capture runner (which, for a rig that stores sweep analyses,
// analyses every sweep while its frames arrive) share this, so both derive
// the planes the same way.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calibration/camera_rays.h"
#include "calibration/laser_line.h"
#include "core/plane.h"
#include "formats/calibration.h"
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/rig_description.h"
#include "mdf/laser_sweep.h"

namespace mesocap::mdf {

struct SweepGeometryOptions {
  calibration::LaserLineOptions line;
  // The reference region: the turntable outside the sample square grown by
  // this margin, within reference_extent x the sample size of the centre.
  double reference_margin_mm = 1.0;
  double reference_extent = 1.5;

  core::CheckResult Check() const;
};

class SessionSweepGeometry {
 public:
  // Matches every camera of the session's rig with the calibration's (by id,
  // at the size the rig records) and checks the laser mounts; throws Error
  // naming what is missing. Plate frames are read when a location's plane
  // is first needed.
  SessionSweepGeometry(std::filesystem::path session, const formats::SessionManifest& manifest,
                       formats::RigDescription rig, const formats::Calibration& calibration,
                       SweepGeometryOptions options);

  // The rig's camera with this id; throws Error when there is none.
  int CameraIndex(const std::string& id) const;
  const calibration::CameraRays& rays(int camera) const { return rays_.at(camera); }
  const formats::RigDescription& rig() const { return rig_; }

  // A location's plane seen by `camera` at its plates' tilt, fitted from
  // the two plate frames on first use (throws FormatError when the plan
  // lacks them, Error when the stripe is not found on a plate).
  const core::Plane& CalibratedPlane(int location, int camera);

  // The geometry of `step`'s sweep seen by `camera`, for analysing its
  // frames: the location's CalibratedPlane, the reference region at the
  // step's turntable angle, the tilts relative to the plates'.
  SweepGeometry Geometry(const formats::LaserSweepStep& step, int camera);

 private:
  struct Plates {
    double tilt_rad = 0.0;
    std::vector<formats::LaserCalibrationStep> heights;  // the plates' steps
  };

  std::filesystem::path session_;
  std::filesystem::path manifest_file_;
  formats::RigDescription rig_;
  formats::Calibration calibration_;
  SweepGeometryOptions options_;
  std::vector<calibration::CameraRays> rays_;  // per rig camera
  std::map<int, Plates> plates_;  // per location
  std::map<std::pair<int, int>, core::Plane> planes_;  // (location, camera)
  std::map<std::pair<long long, int>, calibration::PixelMask> regions_;  // (turntable micro-degrees, camera)
};

}  // namespace mesocap::mdf
