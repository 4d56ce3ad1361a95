// The rig description file: the nominal geometry of a capture rig as in the
// MDF paper (Sec. 3.1, Fig. 3a), how it is sampled, and which backend drives
// each device. Calibration refines the geometry; the simulated rig takes it
// as the truth.
//
// World frame: origin at the turntable centre on the turntable plane, which
// is the sample's reference plane (z = 0), +z up. The turntable turns the
// sample frame about +z: x_world = Rz(turntable angle) x_sample. The camera
// arc is fixed in the half plane at world azimuth `cameras[i].azimuth`; each
// camera looks at the origin from its elevation and distance. The light arc
// turns about +z; at arc angle a its lamps and the laser mounts lie in the
// half plane at world azimuth a.
#pragma once

#include <array>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/sampling_set.h"

namespace mesocap::formats {

struct CameraDescription {
  std::string id;
  std::string backend;  // "sim" or "aravis"
  // For "aravis": the GenICam device to open, by Aravis device id, serial
  // number or IPv4 address.
  std::string device;
  double azimuth_rad = 0.0;
  double elevation_rad = 0.0;  // above the turntable plane
  double distance_mm = 0.0;    // from the origin to the centre of projection
  int width = 0;
  int height = 0;
  double focal_px = 0.0;
  Eigen::Vector2d principal_point_px = Eigen::Vector2d::Zero();
  std::array<double, 5> distortion{};  // OpenCV k1 k2 p1 p2 k3 (Brown-Conrady)
  int bit_depth = 12;
  double full_well_electrons = 20000.0;  // shot noise: Poisson in electrons
  double read_noise_electrons = 5.0;     // Gaussian, per pixel
  double exposure_us = 20000.0;
};

// A Pololu Tic stepper controller ("backend": "tic"), found by its serial
// number; the steps it counts become angles through the motor's steps, the
// microstepping and the gear.
struct TicDescription {
  std::string serial;
  std::string product = "T825";  // T825, T834, T500, N825, T249, 36v4
  int full_steps_per_revolution = 200;
  int microsteps = 8;
  double gear_ratio = 1.0;  // motor turns per turn of the stage
  bool home_forward = false;
};

// One GPIO line: {"chip": "gpiochip0", "line": 17 or "LINE_NAME",
// "active_low": false}.
struct GpioLineDescription {
  std::string chip;
  int offset = -1;   // or
  std::string name;  // the line's name on its chip
  bool active_low = false;
};

// A stepper driver board on two GPIO lines, homed on a limit switch.
struct StepDirDescription {
  GpioLineDescription step;
  GpioLineDescription direction;
  GpioLineDescription limit_switch;
  int full_steps_per_revolution = 200;
  int microsteps = 16;
  double gear_ratio = 1.0;
  bool home_forward = false;
};

struct StageDescription {
  std::string backend;             // "sim" or "tic"
  TicDescription tic;              // for "tic"
  std::vector<double> angles_rad;  // where captures are taken
  double speed_rad_per_s = 0.5;
};

struct LampBankDescription {
  std::string backend;  // "sim" or "gpiod"
  // For "gpiod": one line per lamp (active: on), optional current-sense
  // input lines, and the lamps' warm-up before a frame.
  std::vector<GpioLineDescription> lines;
  std::vector<GpioLineDescription> sense_lines;  // empty, or one per lamp
  double settle_ms = 200.0;
  double distance_mm = 0.0;                             // from the origin
  std::vector<double> elevations_rad;                   // one lamp per elevation
  Eigen::Vector3d intensity = Eigen::Vector3d::Ones();  // radiant intensity, relative RGB
  // The light-emitting part of each lamp, a sphere of uniform radiance: its
  // irradiance is a point lamp's, but its mirror image on the calibration's
  // mirror sphere has a size (sim/mirror_sphere_renderer.h).
  double emitter_radius_mm = 20.0;
};

// One laser source location: a mount on the light arc and an arc angle.
struct LaserLocation {
  int mount = 0;
  double arc_angle_rad = 0.0;
};

struct LaserDescription {
  std::string backend;  // "sim" or "gpiod"
  // For "gpiod": the enable line, and the tilt motor on a Tic or on a
  // step/dir driver ("tilt": {"backend": "tic", ...} or {"backend": "gpiod", ...}).
  GpioLineDescription enable;
  std::string tilt_backend;
  TicDescription tilt_tic;
  StepDirDescription tilt_stepper;
  double distance_mm = 0.0;  // from the origin to the emitter
  std::vector<double> mount_elevations_rad;
  std::vector<LaserLocation> locations;  // the sweeps taken for every turntable angle
  // The sweep, as the stripe's offset on the turntable plane from the origin
  // along the scan direction (towards the laser's azimuth); the tilt that
  // gives an offset depends on the mount's elevation (LaserTiltForOffset).
  double sweep_min_mm = 0.0;
  double sweep_max_mm = 0.0;
  int frames_per_sweep = 0;
  double stripe_sigma_mm = 0.0;                    // Gaussian profile of the stripe, across it
  double power = 1.0;                              // peak stripe irradiance, relative to lamps
  std::array<double, 2> calibration_heights_mm{};  // Sec. 3.2: two planes of different height
  // What a capture keeps of a sweep: its frames, or only the space-time
  // analysis made while they arrive ("sweep_storage": "analysis"; a
  // paper-size session's frames would be 1.5 TB).
  enum class SweepStorage { kFrames, kAnalysis };
  SweepStorage sweep_storage = SweepStorage::kFrames;
};

// The board at the bottom of the sample's pocket, under the sample. A camera
// ray through a hole in the sample meets it below the mesostructure slab, so
// the laser stripe on it is the evidence for "no hit" (MDF paper Sec. 3.2);
// without a board (depth 0) such a ray sees black and stays unknown. It must
// lie at least kMinBackingClearanceMm below the deepest mesostructure.
struct SampleBacking {
  double depth_mm = 0.0;  // below the reference plane; 0: no board
  double albedo = 0.0;    // diffuse, grey

  bool present() const { return depth_mm > 0.0; }
};
inline constexpr double kMinBackingClearanceMm = 1.0;

// The board of a rig's calibration session ("calibration_board", optional):
// held on the turntable on a holder at each tilt in turn (the operator
// changes the tilt), photographed by every camera at each turntable angle.
// The board's surface lies height_mm above the reference plane on the first
// holder tilt, whose board's x axis sets the sample frame's.
struct CalibrationBoardDescription {
  std::string board;  // a board spec, calibration/calibration_board.h
  double height_mm = 0.0;
  std::vector<double> holder_tilts_rad;  // about the turntable's x axis, the first one 0
  std::vector<double> turntable_angles_rad;
};

// The white reference of a rig's calibration session ("white_reference",
// optional): a flat diffuse plate of known albedo laid over the turntable
// with its top height_mm above the reference plane, imaged by every camera
// under each lamp alone with the light arc at arc_angle; the cameras' gains
// and the lamps' intensities come from it (calibration/radiometric_calibration.h).
struct WhiteReferenceDescription {
  double albedo = 0.0;  // diffuse, grey, in (0, 1]
  double height_mm = 0.0;
  double arc_angle_rad = 0.0;
};

// The mirror sphere of a rig's calibration session ("mirror_sphere",
// optional): a polished ball of known radius in a cup on the turntable, its
// centre offset_mm from the turntable's axis along the sample's x and
// centre_height_mm above the reference plane, imaged by every camera under
// each lamp alone at each of its arc angles (by default the light arc's) and
// each of its turntable angles, at its own exposure (a lamp's mirror image is far brighter than any
// diffuse surface). The lamps' positions and the light arc's axis come from
// the highlights (calibration/light_arc_calibration.h); the offset, turned
// by the turntable, is the baseline that gives the lamps' distances.
struct MirrorSphereDescription {
  double radius_mm = 0.0;
  double offset_mm = 0.0;
  double centre_height_mm = 0.0;
  std::vector<double> turntable_angles_rad = {0.0};
  std::vector<double> arc_angles_rad;
  double reflectance = 0.0;  // specular, grey, in (0, 1]
  double exposure_us = 0.0;  // of every camera, for the sphere's images
};

struct RigDescription {
  std::string name;
  double sample_size_mm = 0.0;  // side of the clipped square sample
  SampleBacking backing;
  std::vector<CameraDescription> cameras;
  StageDescription turntable;
  StageDescription light_arc;
  LampBankDescription lamps;
  LaserDescription laser;
  std::optional<CalibrationBoardDescription> calibration_board;
  std::optional<WhiteReferenceDescription> white_reference;
  std::optional<MirrorSphereDescription> mirror_sphere;
  nlohmann::json json;         // the file as read, kept for the session manifest's rig snapshot
  std::filesystem::path file;  // where it was read from, for messages

  int view_count() const { return static_cast<int>(turntable.angles_rad.size() * cameras.size()); }
  int light_count() const { return static_cast<int>(light_arc.angles_rad.size() * lamps.elevations_rad.size()); }
  // The cameras' ids, in the description's order.
  std::vector<std::string> camera_ids() const {
    std::vector<std::string> ids;
    for (const CameraDescription& c : cameras) ids.push_back(c.id);
    return ids;
  }
};

// Reads and validates a rig description; errors name the file and field.
RigDescription ReadRigDescription(const std::filesystem::path& file);
RigDescription ParseRigDescription(const nlohmann::json& json, const std::filesystem::path& file);

}  // namespace mesocap::formats
