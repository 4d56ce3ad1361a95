// The capture plan of a session (MDF paper Sec. 3.1-3.2): every step the rig
// executes, in the order it executes them, with the files each step writes.
//
//   laser_calibration  per laser location and plate height: the stripe at
//                      tilt 0 on a flat plate (Sec. 3.2 finds the laser
//                      plane's angle from the two heights before scanning)
//   btf_image          per turntable angle x light-arc angle x lamp: one
//                      image per camera, that lamp alone on
//   laser_sweep        per turntable angle x laser location: the stripe
//                      swept across the sample, one frame sequence per camera
//
// Files, relative to the session folder:
//   laser_calibration/loc<li>_h<hi>_<cam>.png   16-bit grey
//   btf/t<ti>_a<ai>_l<lamp>_<cam>.png           16-bit RGB
//   laser/t<ti>_loc<li>_<cam>.tif               16-bit grey frame sequence, or
//   laser/t<ti>_loc<li>_<cam>.sweep.json        its space-time analysis (+ .exr)
//                                               where the rig's sweep_storage
//                                               is "analysis"
// The turntable-major order lets the rig turn the sample once per angle.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "formats/capture_session.h"
#include "formats/rig_description.h"

namespace mesocap::acquisition {

// `recording` (null for none) is stored in every step (ToPlannedStep): the
// settings that shaped the data beyond the rig (for the simulated rig: the
// scene, seed and sensor model), so that resuming a session can check that
// it continues the same capture. The steps' members are those of
// formats/capture_plan_steps.h.
std::vector<formats::PlannedStep> MakeCapturePlan(const formats::RigDescription& rig,
                                                  const nlohmann::json& recording = nullptr);

// The plan of a calibration session (`simulate --plan calibration`): the
// rig's calibration board on each holder tilt in turn (the operator sets it),
// at each of its turntable angles, one image per camera; then, when the rig
// has a mirror_sphere, the sphere at each of its turntable angles under each
// lamp alone at each light-arc angle; then, when it has a white_reference, the reference under each lamp
// alone:
//   board_image        board/h<hi>_t<ti>_<cam>.png   16-bit grey
//   mirror_sphere      sphere/t<ti>_a<ai>_l<lamp>_<cam>.png 16-bit RGB
//   white_reference    white/l<lamp>_<cam>.png       16-bit RGB, as a BTF image
// Throws FormatError naming the rig file when it has no calibration_board.
std::vector<formats::PlannedStep> MakeCalibrationPlan(const formats::RigDescription& rig,
                                                      const nlohmann::json& recording = nullptr);

// The BTF images of the capture plan alone (`simulate --plan btf`): a
// BTF-only session, without the laser calibration and sweeps.
std::vector<formats::PlannedStep> MakeBtfPlan(const formats::RigDescription& rig,
                                              const nlohmann::json& recording = nullptr);

// The kinds of plan a capture station runs, as `simulate --plan`, the daemon's
// jobs and its API name them.
inline const std::vector<std::string> kPlanKinds = {"capture", "btf", "calibration"};

// The plan of one of kPlanKinds. Throws Error naming the kind otherwise.
std::vector<formats::PlannedStep> MakePlanOfKind(const formats::RigDescription& rig, const std::string& plan_kind,
                                                 const nlohmann::json& recording = nullptr);

}  // namespace mesocap::acquisition
