#include "acquisition/capture_plan.h"

#include <cmath>
#include <numbers>
#include <string>

#include "calibration/nominal_geometry.h"

namespace mesocap::acquisition {
namespace {

using nlohmann::json;

json CameraFiles(const formats::RigDescription& rig, const std::string& stem, const std::string& extension) {
  json files = json::array();
  for (const auto& cam : rig.cameras) files.push_back({{"camera", cam.id}, {"path", stem + "_" + cam.id + extension}});
  return files;
}

formats::PlannedStep Step(std::string id, formats::StepKind kind, json params, const json& recording) {
  if (!recording.is_null()) params["recording"] = recording;
  return {std::move(id), kind, std::move(params)};
}

}  // namespace

double PlanDegrees(double rad) { return std::round(rad * (180.0 / std::numbers::pi) * 1e9) / 1e9; }

std::vector<formats::PlannedStep> MakeCapturePlan(const formats::RigDescription& rig, const json& recording) {
  std::vector<formats::PlannedStep> plan;
  const auto& laser = rig.laser;
  for (std::size_t li = 0; li < laser.locations.size(); ++li) {
    const auto& loc = laser.locations[li];
    for (int hi = 0; hi < 2; ++hi) {
      const std::string stem = "loc" + std::to_string(li) + "_h" + std::to_string(hi);
      plan.push_back(Step("laser-calibration-" + stem, formats::StepKind::kLaserCalibration,
                          {{"location", li},
                           {"mount", loc.mount},
                           {"arc_deg", PlanDegrees(loc.arc_angle_rad)},
                           {"height_mm", laser.calibration_heights_mm[hi]},
                           {"tilt_deg", 0.0},
                           {"files", CameraFiles(rig, "laser_calibration/" + stem, ".png")}},
                          recording));
    }
  }
  for (std::size_t ti = 0; ti < rig.turntable.angles_rad.size(); ++ti) {
    const double tt = rig.turntable.angles_rad[ti];
    for (std::size_t ai = 0; ai < rig.light_arc.angles_rad.size(); ++ai) {
      for (std::size_t lamp = 0; lamp < rig.lamps.elevations_rad.size(); ++lamp) {
        const std::string stem =
            "t" + std::to_string(ti) + "_a" + std::to_string(ai) + "_l" + std::to_string(lamp);
        plan.push_back(Step("btf-" + stem, formats::StepKind::kBtfImage,
                            {{"turntable_index", ti},
                             {"turntable_deg", PlanDegrees(tt)},
                             {"arc_index", ai},
                             {"arc_deg", PlanDegrees(rig.light_arc.angles_rad[ai])},
                             {"lamp", lamp},
                             {"lamp_elevation_deg", PlanDegrees(rig.lamps.elevations_rad[lamp])},
                             {"files", CameraFiles(rig, "btf/" + stem, ".png")}},
                            recording));
      }
    }
    for (std::size_t li = 0; li < laser.locations.size(); ++li) {
      const auto& loc = laser.locations[li];
      json offsets = json::array();
      json tilts = json::array();
      for (int f = 0; f < laser.frames_per_sweep; ++f) {
        const double offset =
            laser.sweep_min_mm + (laser.sweep_max_mm - laser.sweep_min_mm) * f / (laser.frames_per_sweep - 1);
        offsets.push_back(std::round(offset * 1e9) / 1e9);
        tilts.push_back(PlanDegrees(calibration::LaserTiltForOffset(laser, loc.mount, offset)));
      }
      const std::string stem = "t" + std::to_string(ti) + "_loc" + std::to_string(li);
      const bool analysis = laser.sweep_storage == formats::LaserDescription::SweepStorage::kAnalysis;
      json params = {{"turntable_index", ti},
                     {"turntable_deg", PlanDegrees(tt)},
                     {"location", li},
                     {"mount", loc.mount},
                     {"arc_deg", PlanDegrees(loc.arc_angle_rad)},
                     {"offset_mm", offsets},
                     {"tilt_deg", tilts},
                     {"files", CameraFiles(rig, "laser/" + stem, analysis ? ".sweep.json" : ".tif")}};
      if (analysis) params["stored_as"] = "analysis";
      plan.push_back(Step("laser-sweep-" + stem, formats::StepKind::kLaserSweep, std::move(params), recording));
    }
  }
  return plan;
}

}  // namespace mesocap::acquisition
