#include "formats/capture_session.h"

#include <algorithm>
#include <cstdio>
#include <ctime>
#include <set>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_field_reader.h"
#include "core/version.h"
#include "formats/calibration.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kSessionFormat = "mesocap.session";
constexpr int kSessionVersion = 2;  // version 1: no checksums
constexpr int kOldestSessionVersion = 1;
// The rig snapshot and step params are free-form; 64 levels is far more than
// any rig description needs and keeps recursive JSON walks safe.
constexpr int kSessionMaxDepth = 64;
constexpr std::size_t kMaxShortText = 256;

bool HasControlCharacter(std::string_view text) {
  for (const unsigned char ch : text) {
    if (ch < 0x20 || ch == 0x7f) return true;
  }
  return false;
}

// A non-empty single-line string of at most kMaxShortText bytes.
std::string ShortText(const core::JsonFieldReader& fields, std::string_view key) {
  const std::string s = fields.String(key);
  if (s.empty() || s.size() > kMaxShortText || HasControlCharacter(s)) {
    fields.Fail(key, "expected 1 to " + std::to_string(kMaxShortText) + " characters without control characters");
  }
  return s;
}

}  // namespace

core::FileChecksum ReadChecksum(const core::JsonFieldReader& fields) {
  core::FileChecksum sum;
  sum.bytes = static_cast<std::uint64_t>(fields.Integer("bytes", 0, kMaxSessionFileBytes));
  const auto hash = core::ParseChecksumText(fields.String("xxh3_64"));
  if (!hash) fields.Fail("xxh3_64", "expected 16 lowercase hexadecimal digits (the file's XXH3-64 hash)");
  sum.xxh3 = *hash;
  return sum;
}

namespace {

PlannedStep ReadStep(const core::JsonFieldReader& fields) {
  PlannedStep step;
  step.id = fields.String("id");
  if (!IsValidId(step.id)) {
    fields.Fail("id", "expected 1 to 128 characters from A-Z a-z 0-9 . _ -");
  }
  step.kind = *core::EnumFromString<StepKind>(fields.Choice("kind", core::EnumStrings<StepKind>()));
  step.params = fields.json();
  step.params.erase("id");
  step.params.erase("kind");
  return step;
}

SessionManifest ParseSessionManifest(const json& document, const fs::path& file) {
  core::RejectDeepNesting(document, file, kSessionMaxDepth);  // again, for manifests about to be written
  const core::JsonFieldReader root(document, file);
  SessionManifest m;
  m.version = root.ExpectFormat(kSessionFormat, kOldestSessionVersion, kSessionVersion);
  root.RejectUnknownMembers({"format", "version", "software_version", "created_utc", "rig", "calibration", "plan"});
  m.software_version = ShortText(root, "software_version");
  m.created_utc = root.String("created_utc");
  if (!IsUtcTimestamp(m.created_utc)) {
    root.Fail("created_utc", "expected an ISO 8601 UTC time such as 2025-06-01T12:34:56Z");
  }
  const core::JsonFieldReader rig = root.Object("rig");
  ShortText(rig, "name");
  m.rig = rig.json();
  if (root.Has("calibration") && m.version == 1) {
    m.calibration = root.String("calibration");
    if (!IsSessionPath(*m.calibration)) {
      root.Fail("calibration", "expected a relative path inside the session folder");
    }
  } else if (root.Has("calibration")) {
    const core::JsonFieldReader calibration = root.Object("calibration");
    calibration.RejectUnknownMembers({"path", "bytes", "xxh3_64"});
    m.calibration = calibration.String("path");
    if (!IsSessionPath(*m.calibration)) {
      calibration.Fail("path", "expected a relative path inside the session folder");
    }
    m.calibration_checksum = ReadChecksum(calibration);
  }
  const core::JsonFieldReader plan = root.Object("plan");
  plan.RejectUnknownMembers({"steps"});
  std::set<std::string> ids;
  for (const auto& fields : plan.Objects("steps", kMaxPlanSteps)) {
    m.plan.push_back(ReadStep(fields));
    if (!ids.insert(m.plan.back().id).second) {
      fields.Fail("id", "duplicate step id \"" + m.plan.back().id + "\"");
    }
  }
  return m;
}

bool IsLeapYear(int y) { return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0; }

int DaysInMonth(int year, int month) {
  static constexpr int kDays[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  return month == 2 && IsLeapYear(year) ? 29 : kDays[month - 1];
}

}  // namespace

std::string UtcTimestamp(std::chrono::system_clock::time_point time) {
  const auto seconds = std::chrono::floor<std::chrono::seconds>(time);
  const auto millis = std::chrono::duration_cast<std::chrono::milliseconds>(time - seconds).count();
  const std::time_t t = std::chrono::system_clock::to_time_t(seconds);
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[64];
  std::snprintf(text, sizeof text, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900, utc.tm_mon + 1,
                utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, static_cast<int>(millis));
  return text;
}

bool IsUtcTimestamp(std::string_view text) {
  // Fixed positions of "YYYY-MM-DDTHH:MM:SS"; then optional fraction, then Z.
  constexpr std::string_view kPattern = "dddd-dd-ddTdd:dd:dd";
  if (text.size() < kPattern.size() + 1 || text.back() != 'Z') return false;
  for (std::size_t i = 0; i < kPattern.size(); ++i) {
    const bool digit = text[i] >= '0' && text[i] <= '9';
    if (kPattern[i] == 'd' ? !digit : text[i] != kPattern[i]) return false;
  }
  const auto number = [&](std::size_t at, std::size_t n) {
    int v = 0;
    for (std::size_t i = at; i < at + n; ++i) v = 10 * v + (text[i] - '0');
    return v;
  };
  const int year = number(0, 4), month = number(5, 2), day = number(8, 2);
  if (month < 1 || month > 12 || day < 1 || day > DaysInMonth(year, month)) return false;
  if (number(11, 2) > 23 || number(14, 2) > 59 || number(17, 2) > 60) return false;
  const std::string_view fraction = text.substr(kPattern.size(), text.size() - kPattern.size() - 1);
  if (fraction.empty()) return true;
  if (fraction.size() < 2 || fraction.size() > 10 || fraction[0] != '.') return false;
  for (const char ch : fraction.substr(1)) {
    if (ch < '0' || ch > '9') return false;
  }
  return true;
}

bool IsSessionPath(std::string_view path) {
  if (path.empty() || path.size() > 1024 || path.front() == '/') return false;
  if (HasControlCharacter(path) || path.find('\\') != std::string_view::npos) return false;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    const std::string_view part = path.substr(start, end - start);
    if (part.empty() || part == "." || part == "..") return false;
    if (end == path.size()) return true;
    start = end + 1;
  }
}

json ToJson(const SessionManifest& m) {
  json steps = json::array();
  for (const auto& step : m.plan) {
    if (!step.params.is_object() || step.params.contains("id") || step.params.contains("kind")) {
      throw core::Error("plan step \"" + step.id + "\": params must be a JSON object without \"id\" or \"kind\"");
    }
    json s = step.params;
    s["id"] = step.id;
    s["kind"] = ToString(step.kind);
    steps.push_back(std::move(s));
  }
  json j = {{"format", kSessionFormat},
            {"version", kSessionVersion},
            {"software_version", m.software_version},
            {"created_utc", m.created_utc},
            {"rig", m.rig},
            {"plan", {{"steps", std::move(steps)}}}};
  if (m.calibration && !m.calibration_checksum) {
    throw core::Error("session manifest: the calibration " + *m.calibration + " needs its size and hash");
  }
  if (m.calibration) {
    j["calibration"] = {{"path", *m.calibration},
                        {"bytes", m.calibration_checksum->bytes},
                        {"xxh3_64", core::ChecksumText(m.calibration_checksum->xxh3)}};
  }
  return j;
}

void CreateCaptureSession(const fs::path& dir, SessionManifest manifest) {
  if (manifest.software_version.empty()) manifest.software_version = core::Version();
  if (manifest.created_utc.empty()) {
    manifest.created_utc = UtcTimestamp(std::chrono::system_clock::now());
  }
  const fs::path manifest_file = dir / kSessionManifestName;
  const json document = ToJson(manifest);
  ParseSessionManifest(document, manifest_file);
  try {
    (void)document.dump();
  } catch (const json::exception& e) {
    // nlohmann refuses to write strings that are not UTF-8 (say in the rig);
    // find out before touching the disk.
    throw core::Error(manifest_file.string() + ": cannot write the manifest: " + e.what());
  }

  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) throw core::Error(dir.string() + ": exists and is not a folder");
    // A run killed while creating the session left at most its manifest's temporary.
    core::RemoveStaleTemporariesOf(manifest_file);
    if (!fs::is_empty(dir, ec) || ec) {
      throw core::Error(dir.string() + ": already holds files; a new session needs an empty folder");
    }
  } else {
    fs::create_directories(dir, ec);
    if (ec) throw core::Error(dir.string() + ": cannot create folder: " + ec.message());
    // Make the new folder's own entry durable, not just what goes inside it.
    fs::path full = fs::absolute(dir).lexically_normal();
    if (!full.has_filename()) full = full.parent_path();  // "a/b/" -> "a/b"
    core::SyncPath(full.parent_path());
  }
  core::WriteJsonFileAtomically(manifest_file, document);
}

core::ImageReadOptions SessionFrameReadOptions(int width, int height, int channels) {
  core::ImageReadOptions read;
  read.expected_width = width;
  read.expected_height = height;
  read.expected_channels = channels;
  read.expected_encoding = kSessionFrameEncoding;
  return read;
}

SessionManifest ReadSessionManifest(const fs::path& dir) {
  const fs::path file = dir / kSessionManifestName;
  return ParseSessionManifest(core::ReadJsonFile(file, kMaxSessionManifestBytes, kSessionMaxDepth), file);
}

}  // namespace mesocap::formats
