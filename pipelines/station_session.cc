#include "pipelines/station_session.h"

#include <spdlog/spdlog.h>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_field_reader.h"
#include "formats/capture_plan_steps.h"

namespace mesocap::pipelines {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr const char* kCalibrationFile = "calibration.json";

// Where `old` and `now` first differ, as "FIELD was X, now Y" (FIELD a path
// such as "cameras[0].bit_depth" below `where`).
std::string FirstDifference(const json& old, const json& now, const std::string& where) {
  const json patch = json::diff(old, now);
  if (patch.empty()) return where + " is the same";
  const json::json_pointer pointer(patch[0].at("path").get<std::string>());
  std::vector<std::string> parts;
  for (json::json_pointer p = pointer; !p.empty(); p = p.parent_pointer()) parts.push_back(p.back());
  std::string field = where;
  for (auto part = parts.rbegin(); part != parts.rend(); ++part) {
    const bool index = !part->empty() && part->find_first_not_of("0123456789") == std::string::npos;
    field += index ? "[" + *part + "]" : "." + *part;
  }
  const auto value = [&](const json& document) {
    return document.contains(pointer) ? core::JsonExcerpt(document.at(pointer)) : std::string("absent");
  };
  return core::Cut(field) + " was " + value(old) + ", now " + value(now);
}

json PlanJson(const std::vector<formats::PlannedStep>& plan) {
  formats::SessionManifest m;
  m.rig = {{"name", "-"}};
  m.plan = plan;
  return ToJson(m).at("plan");
}

// The options live in each step's "recording", the same in every step of a
// session; a plan that differs elsewhere, or whose steps disagree, is not a
// change of options but a damaged manifest (or another version's plan).
[[noreturn]] void ThrowPlanDifference(const fs::path& dir, const json& old_plan, const json& new_plan) {
  const json& old_steps = old_plan.at("steps");
  const json old_recording = old_steps.empty() ? json() : old_steps.at(0).value("recording", json());
  const json new_recording =
      new_plan.at("steps").empty() ? json() : new_plan.at("steps").at(0).value("recording", json());
  for (std::size_t s = 1; s < old_steps.size(); ++s) {
    if (old_steps.at(s).value("recording", json()) != old_recording) {
      throw core::FormatError(dir / formats::kSessionManifestName, "plan[" + std::to_string(s) + "].recording",
                              "differs from plan[0].recording, which every step shares: the manifest is damaged");
    }
  }
  if (old_recording != new_recording) {
    throw core::Error(dir.string() + ": the session was started with other options: " +
                      FirstDifference(old_recording, new_recording, "recording"));
  }
  throw core::Error(dir.string() + ": the session's plan differs from the one this rig and these options give (" +
                    FirstDifference(old_plan, new_plan, "plan") +
                    "): its manifest is damaged or was written by another mesocap version");
}

}  // namespace

void OpenStationSession(const fs::path& dir, const StationSession& session) {
  const bool existing = fs::exists(dir / formats::kSessionManifestName);
  if (existing) {
    const formats::SessionManifest manifest = formats::ReadSessionManifest(dir);
    // A damaged step is named as such, not taken for a change of options below.
    formats::CheckPlanSteps(manifest, dir / formats::kSessionManifestName);
    // A resumed session must be the same capture: same rig, and the same
    // recording options (a simulated rig's scene, seed, noise and sampling),
    // all in the plan's step params.
    if (manifest.rig != session.rig) {
      throw core::Error(dir.string() + ": the session was started with another rig: " +
                        FirstDifference(manifest.rig, session.rig, "rig"));
    }
    const json old_plan = PlanJson(manifest.plan), new_plan = PlanJson(session.plan);
    if (old_plan != new_plan) ThrowPlanDifference(dir, old_plan, new_plan);
    if (manifest.calibration_checksum && *manifest.calibration_checksum != session.calibration_checksum) {
      throw core::Error(dir.string() + ": the session records another calibration than " + session.calibration_origin +
                        " (" + formats::kSessionManifestName + " calibration.xxh3_64)");
    }
  } else {
    // A folder without a manifest is a session whose creation was killed:
    // CreateCaptureSession clears what that run left.
    formats::SessionManifest manifest;
    manifest.rig = session.rig;
    manifest.calibration = kCalibrationFile;
    manifest.calibration_checksum = session.calibration_checksum;
    manifest.plan = session.plan;
    formats::CreateCaptureSession(dir, manifest);
  }
  // Written after the manifest, and again when a resume finds it missing or damaged.
  if (const std::string problem = core::ChecksumProblem(dir / kCalibrationFile, session.calibration_checksum);
      !problem.empty()) {
    if (existing) spdlog::warn("{}: {} {}; writing it again", dir.string(), kCalibrationFile, problem);
    core::WriteTextFileAtomically(dir / kCalibrationFile, session.calibration_text);
  }
}

}  // namespace mesocap::pipelines
