// The rig calibration (docs/ARCHITECTURE.md "On disk"; docs/FORMATS.md "Calibration"):
// cameras on a fixed arc, a turntable carrying the sample, and a light arc
// rotating in azimuth that carries the lamps and the laser unit's mount
// positions (Wang et al. 2005, Sec. 3.1). One JSON file, version 2 (version 1,
// the same without camera radiometry, still reads).
//
// Frames: "world" is fixed to the rig. The "turntable" frame coincides with
// world at turntable angle 0 and turns with the table about its axis; the
// "light_arc" frame does the same for the light arc. Angles turn by the right
// hand rule about the axis direction. Lengths are mm; angles are radians here
// and degrees in the file.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/rigid_transform.h"

namespace mesocap::formats {

// Each parameter group carries an `uncertainty` with one standard deviation
// per parameter; empty where the calibration did not estimate it.

struct Intrinsics {  // OpenCV pinhole model, pixels
  double fx = 1, fy = 1, cx = 0, cy = 0;
  struct Uncertainty {
    std::optional<double> fx, fy, cx, cy;
  } uncertainty;
};

struct Distortion {  // OpenCV Brown-Conrady coefficients
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  struct Uncertainty {
    std::optional<double> k1, k2, p1, p2, k3;
  } uncertainty;
};

struct CalibratedPose {
  core::RigidTransform transform;
  // rotation_rad: the small rotation vector (axis * angle) about the parent's
  // axes by which the true rotation differs, per axis.
  struct Uncertainty {
    std::optional<Eigen::Vector3d> rotation_rad, translation_mm;
  } uncertainty;
};

// The range of a camera's gain: it catches garbage (0, 1e308) and keeps the
// radiance per signal value, 1 / (t G), finite for any real exposure.
inline constexpr double kMinCameraGain = 1e-30;
inline constexpr double kMaxCameraGain = 1e30;

// A camera's radiometric gain G: its linear signal (fraction of full scale)
// is L t G for radiance L (the rig's relative units, lamp intensity / mm^2)
// and exposure t (btf/btf_assembly.h, "Radiometry").
struct CameraRadiometry {
  double signal_per_radiance_second = 1;  // G, in [kMinCameraGain, kMaxCameraGain]
  struct Uncertainty {
    std::optional<double> signal_per_radiance_second;
  } uncertainty;
};

struct CameraCalibration {
  std::string id;
  int width = 0, height = 0;  // image size in pixels
  Intrinsics intrinsics;
  Distortion distortion;
  CalibratedPose pose;                         // world <- camera:<id>
  std::optional<CameraRadiometry> radiometry;  // absent where not calibrated
};

struct TurntableCalibration {
  Eigen::Vector3d axis_point_mm = Eigen::Vector3d::Zero();    // world
  Eigen::Vector3d axis_direction = Eigen::Vector3d::UnitZ();  // world, unit
  CalibratedPose sample_pose;                                 // turntable <- sample
  struct Uncertainty {
    std::optional<Eigen::Vector3d> axis_point_mm, axis_direction;
  } uncertainty;
};

struct LightArcCalibration {
  Eigen::Vector3d axis_point_mm = Eigen::Vector3d::Zero();    // world
  Eigen::Vector3d axis_direction = Eigen::Vector3d::UnitZ();  // world, unit
  struct Uncertainty {
    std::optional<Eigen::Vector3d> axis_point_mm, axis_direction;
  } uncertainty;
};

struct LampCalibration {
  std::string id;
  Eigen::Vector3d position_mm = Eigen::Vector3d::Zero();  // light_arc frame
  Eigen::Vector3d intensity = Eigen::Vector3d::Ones();    // RGB radiant intensity, relative
  struct Uncertainty {
    std::optional<Eigen::Vector3d> position_mm, intensity;
  } uncertainty;
};

// A position of the laser unit on the light arc. The laser plane contains the
// source; tilting by t turns its normal about tilt_axis (which lies in the
// plane) by t, so the plane sweeps across the turntable.
struct LaserMountCalibration {
  std::string id;
  Eigen::Vector3d source_mm = Eigen::Vector3d::Zero();                   // light_arc frame
  Eigen::Vector3d plane_normal_at_zero_tilt = Eigen::Vector3d::UnitX();  // light_arc, unit
  Eigen::Vector3d tilt_axis = Eigen::Vector3d::UnitY();                  // light_arc, unit
  Eigen::Vector2d tilt_range_rad = Eigen::Vector2d(-0.5, 0.5);           // [min, max]
  struct Uncertainty {
    std::optional<Eigen::Vector3d> source_mm, plane_normal_at_zero_tilt, tilt_axis;
    std::optional<Eigen::Vector2d> tilt_range_rad;
  } uncertainty;
};

struct Calibration {
  std::vector<CameraCalibration> cameras;  // at least one
  TurntableCalibration turntable;
  LightArcCalibration light_arc;
  std::vector<LampCalibration> lamps;
  std::vector<LaserMountCalibration> laser_mounts;
};

// At most this many cameras, lamps and laser mounts each.
inline constexpr std::size_t kMaxRigParts = 256;
inline constexpr std::uintmax_t kMaxCalibrationBytes = 16ull << 20;

// Validates everything; throws FormatError naming the file, the field path
// and what was expected.
Calibration ReadCalibration(const std::filesystem::path& file);
// Whether `file` says it is a calibration ("format": "mesocap.calibration"):
// what --replace of a calibration output may replace.
bool IsCalibrationFile(const std::filesystem::path& file);
// Validates as ReadCalibration would (so it never writes a file it would
// reject), then replaces `file` atomically.
void WriteCalibration(const std::filesystem::path& file, const Calibration& calibration);
// The exact bytes WriteCalibration writes (validated the same way), so that a
// session can record the file's checksum before writing it.
std::string CalibrationText(const Calibration& calibration);
nlohmann::json ToJson(const Calibration& calibration);

// Ids of rig parts (and of capture steps, formats/capture_session.h): 1 to 128
// characters from A-Z a-z 0-9 '.' '_' '-', so they are safe in frame names
// and file names.
bool IsValidId(std::string_view id);

}  // namespace mesocap::formats
