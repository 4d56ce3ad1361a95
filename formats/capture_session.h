// A capture session on disk (docs/ARCHITECTURE.md "On disk"; docs/FORMATS.md "Capture
// session"): a folder holding
//   manifest.json   what is captured: rig snapshot, calibration, plan, version
//   journal.jsonl   the steps completed so far (formats/capture_journal.h)
//   ...             the captured data, at paths the journal names
// The manifest is written once, atomically, when the session is created.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/enum_text.h"
#include "core/file_checksum.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"

namespace mesocap::formats {

inline constexpr const char* kSessionManifestName = "manifest.json";
inline constexpr const char* kSessionJournalName = "journal.jsonl";

inline constexpr std::size_t kMaxPlanSteps = 100'000;
inline constexpr std::uintmax_t kMaxSessionManifestBytes = 16ull << 20;

enum class StepKind { kBtfImage, kLaserSweep, kLaserCalibration, kBoardImage, kWhiteReference, kMirrorSphere, kOther };

constexpr auto EnumNamesOf(StepKind) {
  return std::to_array(
      {"btf_image", "laser_sweep", "laser_calibration", "board_image", "white_reference", "mirror_sphere", "other"});
}
using core::ToString;

struct PlannedStep {
  std::string id;  // unique in the plan; IsValidId (formats/calibration.h)
  StepKind kind = StepKind::kOther;
  // The step's other members, kept as written; formats/capture_plan_steps.h
  // reads and writes those of the kinds the rig runs.
  // An object without "id" or "kind".
  nlohmann::json params = nlohmann::json::object();
};

struct SessionManifest {
  int version = 2;               // of the manifest read; version 1 records no checksums
  std::string software_version;  // CreateCaptureSession fills an empty one with Version()
  std::string created_utc;       // UtcTimestamp(); CreateCaptureSession fills an empty one
  // The rig as configured for this session, kept as given; must hold a
  // non-empty string "name".
  nlohmann::json rig = nlohmann::json::object();
  // The calibration in use, as a path inside the session folder, with its
  // size and hash (version 2: required with the path; the file is written
  // after the manifest, so its checksum is known before it exists).
  std::optional<std::string> calibration;
  std::optional<core::FileChecksum> calibration_checksum;
  std::vector<PlannedStep> plan;
};

// Creates `dir` (or uses it when it exists and is empty) and writes its
// manifest atomically. Refuses a folder that holds anything, so an existing
// session is never overwritten. Validates the manifest as
// ReadSessionManifest would.
void CreateCaptureSession(const std::filesystem::path& dir, SessionManifest manifest);
// Reads and validates dir/manifest.json.
SessionManifest ReadSessionManifest(const std::filesystem::path& dir);
nlohmann::json ToJson(const SessionManifest& manifest);

// How a session's camera frames are read: the camera's size, `channels`
// (1 grey, 3 RGB) and 16 bits per sample, as docs/FORMATS.md "Capture
// session" requires; an 8-bit frame is refused even behind a matching hash.
core::ImageReadOptions SessionFrameReadOptions(int width, int height, int channels);
inline constexpr core::PixelEncoding kSessionFrameEncoding = core::PixelEncoding::kUInt16;

inline constexpr std::int64_t kMaxSessionFileBytes = std::int64_t{1} << 62;
// {"bytes": N, "xxh3_64": "16 hex digits"} inside `fields` (a calibration
// entry, a journal file); FormatError naming the field otherwise.
core::FileChecksum ReadChecksum(const core::JsonFieldReader& fields);

// "2025-06-01T12:34:56.789Z": ISO 8601, UTC, milliseconds.
std::string UtcTimestamp(std::chrono::system_clock::time_point time);
// "YYYY-MM-DDTHH:MM:SS" with optional ".f" (1 to 9 digits) and a final "Z".
bool IsUtcTimestamp(std::string_view text);

// A path inside the session folder, as files name their data: '/'-separated,
// relative, each part non-empty and not "." or "..", no control characters,
// at most 1024 bytes. Keeps every reference inside the session.
bool IsSessionPath(std::string_view path);

}  // namespace mesocap::formats
