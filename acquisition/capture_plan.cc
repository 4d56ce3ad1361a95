#include "acquisition/capture_plan.h"

#include <algorithm>
#include <numeric>
#include <string>

#include "calibration/nominal_geometry.h"
#include "core/error.h"
#include "formats/capture_plan_steps.h"

namespace mesocap::acquisition {
namespace {

std::vector<formats::CameraFile> CameraFiles(const formats::RigDescription& rig, const std::string& stem,
                                             const std::string& extension) {
  std::vector<formats::CameraFile> files;
  for (const auto& cam : rig.cameras) files.push_back({cam.id, stem + "_" + cam.id + extension});
  return files;
}

// The stripe of laser location `li` at `tilt_rad` on the plate at its
// `hi`-th calibration height (MDF paper Sec. 3.2).
formats::PlannedStep LaserPlateStep(const formats::RigDescription& rig, std::size_t li, int hi, double tilt_rad,
                                    const std::string& stem, const nlohmann::json& recording) {
  const formats::LaserLocation& loc = rig.laser.locations[li];
  formats::LaserCalibrationStep step;
  step.location = static_cast<int>(li);
  step.mount = loc.mount;
  step.arc_rad = loc.arc_angle_rad;
  step.height_mm = rig.laser.calibration_heights_mm[hi];
  step.tilt_rad = tilt_rad;
  step.files = CameraFiles(rig, "laser_calibration/" + stem, ".png");
  return formats::ToPlannedStep("laser-calibration-" + stem, step, recording);
}

// The laser locations in the order their stripes are imaged on the plate at
// its `hi`-th height. One height after the other, so that the operator lays
// each plate once; the second in reverse, so that the laser unit stays on the
// mount the first ended on.
std::vector<std::size_t> PlateOrder(const formats::LaserDescription& laser, int hi) {
  std::vector<std::size_t> order(laser.locations.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  if (hi % 2 == 1) std::reverse(order.begin(), order.end());
  return order;
}

}  // namespace

std::vector<formats::PlannedStep> MakeCapturePlan(const formats::RigDescription& rig, const nlohmann::json& recording) {
  std::vector<formats::PlannedStep> plan;
  const auto& laser = rig.laser;
  for (int hi = 0; hi < 2; ++hi) {
    for (const std::size_t li : PlateOrder(laser, hi)) {
      plan.push_back(
          LaserPlateStep(rig, li, hi, 0.0, "loc" + std::to_string(li) + "_h" + std::to_string(hi), recording));
    }
  }
  for (std::size_t ti = 0; ti < rig.turntable.angles_rad.size(); ++ti) {
    for (std::size_t ai = 0; ai < rig.light_arc.angles_rad.size(); ++ai) {
      for (std::size_t lamp = 0; lamp < rig.lamps.elevations_rad.size(); ++lamp) {
        const std::string stem = "t" + std::to_string(ti) + "_a" + std::to_string(ai) + "_l" + std::to_string(lamp);
        formats::BtfImageStep step;
        step.turntable_index = static_cast<int>(ti);
        step.turntable_rad = rig.turntable.angles_rad[ti];
        step.arc_index = static_cast<int>(ai);
        step.arc_rad = rig.light_arc.angles_rad[ai];
        step.lamp = static_cast<int>(lamp);
        step.lamp_elevation_rad = rig.lamps.elevations_rad[lamp];
        step.files = CameraFiles(rig, "btf/" + stem, ".png");
        plan.push_back(formats::ToPlannedStep("btf-" + stem, step, recording));
      }
    }
  }
  // The sweeps one mount after the other, first location's first (the
  // plates ended on it), so that the operator remounts the laser unit once a
  // mount.
  std::vector<int> mounts;
  for (const formats::LaserLocation& loc : laser.locations) {
    if (std::find(mounts.begin(), mounts.end(), loc.mount) == mounts.end()) mounts.push_back(loc.mount);
  }
  for (const int mount : mounts) {
    for (std::size_t ti = 0; ti < rig.turntable.angles_rad.size(); ++ti) {
      for (std::size_t li = 0; li < laser.locations.size(); ++li) {
        const auto& loc = laser.locations[li];
        if (loc.mount != mount) continue;
        const std::string stem = "t" + std::to_string(ti) + "_loc" + std::to_string(li);
        formats::LaserSweepStep step;
        step.turntable_index = static_cast<int>(ti);
        step.turntable_rad = rig.turntable.angles_rad[ti];
        step.location = static_cast<int>(li);
        step.mount = loc.mount;
        step.arc_rad = loc.arc_angle_rad;
        for (int f = 0; f < laser.frames_per_sweep; ++f) {
          const double offset =
              laser.sweep_min_mm + (laser.sweep_max_mm - laser.sweep_min_mm) * f / (laser.frames_per_sweep - 1);
          step.offsets_mm.push_back(offset);
          step.tilts_rad.push_back(calibration::LaserTiltForOffset(laser, loc.mount, offset));
        }
        step.stores_analysis = laser.sweep_storage == formats::LaserDescription::SweepStorage::kAnalysis;
        step.files = CameraFiles(rig, "laser/" + stem, step.stores_analysis ? ".sweep.json" : ".tif");
        plan.push_back(formats::ToPlannedStep("laser-sweep-" + stem, step, recording));
      }
    }
  }
  return plan;
}

std::vector<formats::PlannedStep> MakeBtfPlan(const formats::RigDescription& rig, const nlohmann::json& recording) {
  std::vector<formats::PlannedStep> plan;
  for (formats::PlannedStep& step : MakeCapturePlan(rig, recording)) {
    if (step.kind == formats::StepKind::kBtfImage) plan.push_back(std::move(step));
  }
  return plan;
}

std::vector<formats::PlannedStep> MakeCalibrationPlan(const formats::RigDescription& rig,
                                                      const nlohmann::json& recording) {
  if (!rig.calibration_board) {
    throw core::FormatError(rig.file, "calibration_board",
                            "missing: a calibration session needs the rig's calibration board (docs/FORMATS.md)");
  }
  const formats::CalibrationBoardDescription& board = *rig.calibration_board;
  std::vector<formats::PlannedStep> plan;
  for (std::size_t h = 0; h < board.holder_tilts_rad.size(); ++h) {
    for (std::size_t ti = 0; ti < board.turntable_angles_rad.size(); ++ti) {
      const std::string stem = "h" + std::to_string(h) + "_t" + std::to_string(ti);
      formats::BoardImageStep step;
      step.holder = static_cast<int>(h);
      step.holder_tilt_rad = board.holder_tilts_rad[h];
      step.turntable_index = static_cast<int>(ti);
      step.turntable_rad = board.turntable_angles_rad[ti];
      step.files = CameraFiles(rig, "board/" + stem, ".png");
      plan.push_back(formats::ToPlannedStep("board-" + stem, step, recording));
    }
  }
  if (rig.mirror_sphere) {
    const std::vector<double>& turns = rig.mirror_sphere->turntable_angles_rad;
    for (std::size_t t = 0; t < turns.size(); ++t) {
      for (std::size_t a = 0; a < rig.mirror_sphere->arc_angles_rad.size(); ++a) {
        for (std::size_t lamp = 0; lamp < rig.lamps.elevations_rad.size(); ++lamp) {
          const std::string stem = "t" + std::to_string(t) + "_a" + std::to_string(a) + "_l" + std::to_string(lamp);
          formats::MirrorSphereStep step;
          step.turntable_index = static_cast<int>(t);
          step.turntable_rad = turns[t];
          step.arc_index = static_cast<int>(a);
          step.arc_rad = rig.mirror_sphere->arc_angles_rad[a];
          step.lamp = static_cast<int>(lamp);
          step.files = CameraFiles(rig, "sphere/" + stem, ".png");
          plan.push_back(formats::ToPlannedStep("sphere-" + stem, step, recording));
        }
      }
    }
  }
  if (rig.white_reference) {
    for (std::size_t lamp = 0; lamp < rig.lamps.elevations_rad.size(); ++lamp) {
      const std::string stem = "l" + std::to_string(lamp);
      formats::WhiteReferenceStep step;
      step.lamp = static_cast<int>(lamp);
      step.arc_rad = rig.white_reference->arc_angle_rad;
      step.files = CameraFiles(rig, "white/" + stem, ".png");
      plan.push_back(formats::ToPlannedStep("white-" + stem, step, recording));
    }
  }
  // The laser mounts: each location's stripe on the two plates (Sec. 3.2) at
  // both ends of its sweep, so the planes at two tilts meet on the tilt
  // axis.
  const formats::LaserDescription& laser = rig.laser;
  for (int hi = 0; hi < 2; ++hi) {
    for (const std::size_t li : PlateOrder(laser, hi)) {
      const int mount = laser.locations[li].mount;
      const double tilts[2] = {calibration::LaserTiltForOffset(laser, mount, laser.sweep_min_mm),
                               calibration::LaserTiltForOffset(laser, mount, laser.sweep_max_mm)};
      for (int k = 0; k < 2; ++k) {
        const std::string stem = "loc" + std::to_string(li) + "_k" + std::to_string(k) + "_h" + std::to_string(hi);
        plan.push_back(LaserPlateStep(rig, li, hi, tilts[k], stem, recording));
      }
    }
  }
  return plan;
}

std::vector<formats::PlannedStep> MakePlanOfKind(const formats::RigDescription& rig, const std::string& plan_kind,
                                                 const nlohmann::json& recording) {
  if (plan_kind == "capture") return MakeCapturePlan(rig, recording);
  if (plan_kind == "btf") return MakeBtfPlan(rig, recording);
  if (plan_kind == "calibration") return MakeCalibrationPlan(rig, recording);
  throw core::Error("plan kind " + core::Quoted(plan_kind) + ": expected \"capture\", \"btf\" or \"calibration\"");
}

}  // namespace mesocap::acquisition
