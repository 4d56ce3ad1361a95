// The laser geometry of a capture session's sweeps (MDF paper Sec. 3.2):
// each laser location's plane, per camera, from its two calibration plates;
// each sweep's poses, reference region and per-frame tilts; and where a
// camera's analysis of a sweep goes in the MDF (its view and merge weight).
// `mesocap process mdf`, the capture runner (which, for a rig that stores
// sweep analyses, analyses every sweep while its frames arrive) and the
// simulated scan of the tests all go through this, so they derive the
// planes and poses the same way.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "calibration/camera_rays.h"
#include "calibration/laser_line.h"
#include "calibration/laser_plane_calibration.h"
#include "calibration/rig_frames.h"
#include "core/image.h"
#include "core/plane.h"
#include "core/rigid_transform.h"
#include "core/sampling_set.h"
#include "formats/calibration.h"
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/rig_description.h"
#include "mdf/laser_sweep.h"
#include "mdf/mdf_assembler.h"

namespace mesocap::mdf {

struct SweepGeometryOptions {
  calibration::LaserLineOptions line;
  // The reference region: the turntable outside the sample square grown by
  // this margin, within reference_extent x the sample size of the centre.
  double reference_margin_mm = 1.0;
  double reference_extent = 1.5;

  core::CheckResult Check() const;
};

// One sweep's poses in the calibrated rig, computed once per sweep: the
// sample in the world at the sweep's turntable angle, and the laser mount on
// the light arc at tilt 0 (the frames' tilts turn its plane about
// mount.tilt_axis).
struct SweepPoses {
  core::RigidTransform world_from_sample;
  core::RigidTransform sample_from_world;
  calibration::LaserMountPose mount;
};

class SessionSweepGeometry {
 public:
  // Plate `plate` (0 or 1, in plan order) of laser location `location` as
  // the rig's camera `camera` saw it: one grey frame.
  using PlateFrame = std::function<core::Image(int location, int plate, int camera)>;

  // Matches every camera of the session's rig with the calibration's (by id,
  // at the size the rig records) and checks the laser mounts; throws Error
  // naming what is missing. Plate frames are read from the session folder
  // when a location's plane is first needed.
  // A session file's full path, once checked (CapturedSession::IntactFile
  // when processing; the capture itself reads what it has just journaled).
  using SessionFiles = std::function<std::filesystem::path(const std::string& path)>;
  SessionSweepGeometry(const std::filesystem::path& manifest_file, const formats::SessionManifest& manifest,
                       SessionFiles files, formats::RigDescription rig, const formats::Calibration& calibration,
                       SweepGeometryOptions options);
  // The same for a capture that never reaches the disk (the simulated scan
  // of the tests): the plan's laser_calibration steps and their frames.
  SessionSweepGeometry(formats::RigDescription rig, const formats::Calibration& calibration,
                       std::vector<formats::LaserCalibrationStep> plates, PlateFrame plate_frame,
                       SweepGeometryOptions options);

  // The rig's camera with this id; throws Error when there is none.
  int CameraIndex(const std::string& id) const;
  const calibration::CameraRays& rays(int camera) const { return rays_.at(camera); }
  const formats::RigDescription& rig() const { return rig_; }

  // A location's plane seen by `camera` at its plates' tilt, fitted from
  // the two plate frames on first use (throws FormatError when the plan
  // lacks them, Error when the stripe is not found on a plate).
  const core::Plane& CalibratedPlane(int location, int camera);
  // The planes fitted so far, with their uncertainty, by (location, camera).
  const std::map<std::pair<int, int>, calibration::LaserPlaneFit>& calibrated_planes() const { return planes_; }

  SweepPoses Poses(const formats::LaserSweepStep& step) const;

  // The geometry of `step`'s sweep seen by `camera`, for analysing its
  // frames: the location's CalibratedPlane, the reference region at the
  // step's turntable angle, the tilts relative to the plates'.
  SweepGeometry Geometry(const formats::LaserSweepStep& step, const SweepPoses& poses, int camera);

  // The view `camera` measures in a sweep: the views' direction nearest to
  // the camera's, seen from the sample.
  int View(const core::SamplingSet& views, const SweepPoses& poses, int camera) const;
  // Adds `camera`'s analysis of `step`'s sweep to the MDF in its View, with
  // the sweep's ScanWeight (Sec. 3.3).
  void AddToMdf(MdfAssembler& assembler, int view, const formats::LaserSweepStep& step, const SweepPoses& poses,
                int camera, const formats::SweepAnalysis& analysis);

 private:
  struct Plates {
    double tilt_rad = 0.0;
    std::vector<formats::LaserCalibrationStep> heights;  // the plates' steps
  };

  void AddPlate(formats::LaserCalibrationStep plate);
  core::Image ReadPlateFrame(int location, int plate, int camera) const;

  SessionFiles files_;                   // empty for a capture that never reaches the disk
  std::filesystem::path manifest_file_;  // for messages
  PlateFrame plate_frame_;               // ReadPlateFrame when empty
  formats::RigDescription rig_;
  formats::Calibration calibration_;
  SweepGeometryOptions options_;
  std::vector<calibration::CameraRays> rays_;                            // per rig camera
  std::map<int, Plates> plates_;                                         // per location
  std::map<std::pair<int, int>, calibration::LaserPlaneFit> planes_;     // (location, camera)
  std::map<std::pair<long long, int>, calibration::PixelMask> regions_;  // (turntable micro-degrees, camera)
};

}  // namespace mesocap::mdf
