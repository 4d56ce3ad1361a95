// The steps of a capture plan the rig runs (docs/FORMATS.md "Capture
// session", the plan mesocap makes), typed: radians inside, degrees in the
// manifest. This file is the only one that knows a step's members; a
// PlannedStep (formats/capture_session.h) keeps them as written, so a step
// with members beyond these, or of kind "other", survives a rewrite.
//
//   laser_calibration  the stripe on a flat plate at a known height (MDF
//                      paper Sec. 3.2 finds the laser plane from two heights)
//   btf_image          one image per camera, one lamp on
//   laser_sweep        the stripe swept across the sample, one frame sequence
//                      (or its space-time analysis) per camera
//   board_image        a calibration session's: the rig's calibration board
//                      on a holder tilt on the turntable, one image per camera
//   white_reference    a calibration session's: the rig's white reference on
//                      the turntable, one lamp on, one image per camera
//   mirror_sphere      a calibration session's: the rig's mirror sphere at
//                      the sample centre, one lamp on at one light-arc
//                      angle, one image per camera at the sphere's exposure
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <variant>
#include <vector>

#include "formats/capture_session.h"
#include "formats/rig_description.h"

namespace mesocap::formats {

// One camera's file of a step.
struct CameraFile {
  std::string camera;  // the rig's camera id
  std::string path;    // inside the session folder (IsSessionPath)
};

struct LaserCalibrationStep {
  int location = 0;  // index into the rig's laser locations
  int mount = 0;
  double arc_rad = 0.0;
  double height_mm = 0.0;  // the plate's top
  double tilt_rad = 0.0;   // the same on both plates of a location
  std::vector<CameraFile> files;
};

struct BtfImageStep {
  int turntable_index = 0;
  double turntable_rad = 0.0;
  int arc_index = 0;
  double arc_rad = 0.0;
  int lamp = 0;
  double lamp_elevation_rad = 0.0;
  std::vector<CameraFile> files;
};

struct LaserSweepStep {
  int turntable_index = 0;
  double turntable_rad = 0.0;
  int location = 0;  // index into the rig's laser locations
  int mount = 0;
  double arc_rad = 0.0;
  // Per frame: the stripe's offset on the turntable plane and the emitter's tilt.
  std::vector<double> offsets_mm;
  std::vector<double> tilts_rad;
  // Each camera's file is a mesocap.sweep_analysis made during the capture
  // ("stored_as": "analysis"), not a frame sequence.
  bool stores_analysis = false;
  std::vector<CameraFile> files;
};

struct BoardImageStep {
  int holder = 0;  // index into the rig's calibration_board.holder_tilts
  double holder_tilt_rad = 0.0;
  int turntable_index = 0;  // index into calibration_board.turntable_angles
  double turntable_rad = 0.0;
  std::vector<CameraFile> files;
};

struct WhiteReferenceStep {
  int lamp = 0;
  double arc_rad = 0.0;
  std::vector<CameraFile> files;
};

struct MirrorSphereStep {
  int turntable_index = 0;  // into the rig's mirror_sphere turntable angles
  double turntable_rad = 0.0;
  int arc_index = 0;  // into the rig's mirror_sphere arc angles
  double arc_rad = 0.0;
  int lamp = 0;
  std::vector<CameraFile> files;
};

using CaptureStep = std::variant<LaserCalibrationStep, BtfImageStep, LaserSweepStep, BoardImageStep, WhiteReferenceStep,
                                 MirrorSphereStep>;

// A planned step of the type's kind. Angles are written in degrees rounded
// to 1e-9 (and offsets to 1e-9 mm), so that a plan is byte-identical across
// runs and machines. `recording` (null for none) is stored as "recording":
// what shaped the data beyond the rig, which resuming a session compares.
PlannedStep ToPlannedStep(std::string id, const LaserCalibrationStep& step, const nlohmann::json& recording = nullptr);
PlannedStep ToPlannedStep(std::string id, const BtfImageStep& step, const nlohmann::json& recording = nullptr);
PlannedStep ToPlannedStep(std::string id, const LaserSweepStep& step, const nlohmann::json& recording = nullptr);
PlannedStep ToPlannedStep(std::string id, const BoardImageStep& step, const nlohmann::json& recording = nullptr);
PlannedStep ToPlannedStep(std::string id, const WhiteReferenceStep& step, const nlohmann::json& recording = nullptr);
PlannedStep ToPlannedStep(std::string id, const MirrorSphereStep& step, const nlohmann::json& recording = nullptr);

// Reads the plan's step `index`, which must be of the type's kind. Throws
// FormatError naming `manifest_file` and the field ("plan[3].tilt_deg").
// Strict against `rig`: no unknown members; indices (location, mount,
// turntable, arc, lamp) name entries of the rig; one file per camera; a
// sweep has one tilt (in [-90, 90] degrees) and one offset (in [-1e5, 1e5]
// mm) per frame of the rig's sweep.
LaserCalibrationStep ReadLaserCalibrationStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                              const std::filesystem::path& manifest_file);
BtfImageStep ReadBtfImageStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                              const std::filesystem::path& manifest_file);
LaserSweepStep ReadLaserSweepStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                  const std::filesystem::path& manifest_file);
// Needs the rig's calibration_board.
BoardImageStep ReadBoardImageStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                  const std::filesystem::path& manifest_file);
// Needs the rig's white_reference.
WhiteReferenceStep ReadWhiteReferenceStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                          const std::filesystem::path& manifest_file);
// Needs the rig's mirror_sphere.
MirrorSphereStep ReadMirrorSphereStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                                      const std::filesystem::path& manifest_file);
// Any step the rig runs; a step of kind "other" is a FormatError.
CaptureStep ReadCaptureStep(const PlannedStep& step, std::size_t index, const RigDescription& rig,
                            const std::filesystem::path& manifest_file);

const std::vector<CameraFile>& Files(const CaptureStep& step);

// Every step of a kind the rig runs (all but "other"), read as above against
// the manifest's own rig: what a reader of a session (verify, info, process,
// a resumed capture) checks before it trusts the plan. FormatError naming
// the file and the first broken field; a plan of "other" steps alone needs
// no rig.
void CheckPlanSteps(const SessionManifest& manifest, const std::filesystem::path& manifest_file);

}  // namespace mesocap::formats
