// How a capture station (acquisition/capture_station.h) opens a session:
// a new one gets its manifest and the calibration the rig uses; one that
// exists must record the same capture (rig, plan with its recording
// options, calibration), or it is refused with what differs, so a resume
// never mixes two captures in one session.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/file_checksum.h"
#include "formats/capture_session.h"

namespace mesocap::pipelines {

struct StationSession {
  nlohmann::json rig;  // the rig description as the manifest records it
  std::vector<formats::PlannedStep> plan;
  std::string calibration_text;  // written beside the manifest as calibration.json
  core::FileChecksum calibration_checksum;
  std::string calibration_origin;  // for the error: "this rig's true one", "the one mesocapd was given"
};

// Creates the session at `dir` (a folder that does not exist, or one whose
// creation was killed), or checks the one there; in both cases writes its
// calibration.json again when it is missing or damaged. Throws Error naming
// the session and the first field that differs.
void OpenStationSession(const std::filesystem::path& dir, const StationSession& session);

}  // namespace mesocap::pipelines
