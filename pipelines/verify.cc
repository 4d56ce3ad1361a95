#include "pipelines/verify.h"

#include <nlohmann/json.hpp>

#include "calibration/calibration_board.h"
#include "core/file_checksum.h"
#include "core/json_field_reader.h"
#include "formats/capture_journal.h"
#include "formats/capture_plan_steps.h"
#include "formats/captured_session.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"

namespace mesocap::pipelines {
namespace fs = std::filesystem;
namespace {

// The "format" a folder's manifest.json claims, or "" when it has none.
std::string ClaimedFormat(const fs::path& dir) {
  const fs::path file = dir / "manifest.json";
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) return {};
  const nlohmann::json doc = core::ReadJsonFile(file, 16u << 20);
  return doc.is_object() && doc.contains("format") && doc["format"].is_string() ? doc["format"].get<std::string>()
                                                                                : std::string();
}

std::uint64_t SizeOrZero(const fs::path& file) {
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  return ec ? 0 : size;
}

void VerifySession(const fs::path& dir, VerifyReport* report) {
  report->kind = "capture session";
  const formats::SessionManifest manifest = formats::ReadSessionManifest(dir);
  CheckSessionManifest(manifest, dir / formats::kSessionManifestName);
  report->version = manifest.version;
  report->steps_planned = manifest.plan.size();
  std::vector<formats::JournalRecord> records;
  if (formats::JournalExists(dir / formats::kSessionJournalName)) {
    formats::JournalContents journal = formats::ReadCaptureJournal(dir / formats::kSessionJournalName, &manifest);
    report->torn_journal_bytes = journal.dropped_bytes;
    records = std::move(journal.records);
  }
  const auto latest = formats::LatestRecords(records);
  report->steps_done = latest.size();
  if (manifest.calibration) {
    ++report->files_checked;
    report->bytes_checked += SizeOrZero(dir / *manifest.calibration);
  }
  for (const auto& [step, record] : latest) {
    for (const formats::JournalFile& f : record->files) {
      ++report->files_checked;
      report->bytes_checked += SizeOrZero(dir / f.path);
    }
  }
  for (const formats::DamagedFile& d : formats::DamagedSessionFiles(dir, manifest, records)) {
    report->damaged.push_back({d.path, d.step.empty() ? d.problem : d.problem + " (step " + d.step + ")"});
  }
}

void VerifyPackage(const fs::path& dir, VerifyReport* report) {
  report->kind = "material package";
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(dir);
  report->version = manifest.version;
  for (const std::string& name : formats::PackageDataFiles(manifest)) {
    ++report->files_checked;
    report->bytes_checked += SizeOrZero(dir / name);
    const auto it = manifest.checksums.find(name);
    if (it == manifest.checksums.end()) continue;  // version 1: decoded below instead
    if (const std::string problem = core::ChecksumProblem(dir / name, it->second); !problem.empty()) {
      report->damaged.push_back({name, problem});
    }
  }
  if (manifest.version < 2) {
    // No checksums: decoding every part with the readers' checks is the best
    // that can be done, and finds what breaks a codec or a value range.
    try {
      formats::ReadMaterialPackage(dir);
    } catch (const core::FormatError& e) {
      report->damaged.push_back({fs::relative(e.file(), dir).generic_string(), e.what()});
    }
  }
}

}  // namespace

void CheckSessionManifest(const formats::SessionManifest& manifest, const fs::path& manifest_file) {
  formats::CheckPlanSteps(manifest, manifest_file);
  if (manifest.rig.contains("calibration_board")) {
    calibration::RigCalibrationBoard(formats::ParseRigDescription(manifest.rig, manifest_file));
  }
}

core::CheckResult VerifyOptions::Check() const {
  if (path.empty()) return "path: give a capture session or material package folder";
  return {};
}

VerifyReport RunVerify(const VerifyOptions& o) {
  core::ThrowIfInvalid(o.Check(), "verify");
  std::error_code ec;
  if (!fs::is_directory(o.path, ec)) {
    throw core::Error(o.path.string() + ": not a folder; verify checks a capture session or material package");
  }
  const std::string format = ClaimedFormat(o.path);
  VerifyReport report;
  if (format == "mesocap.session") {
    VerifySession(o.path, &report);
  } else if (format == "mesocap.material") {
    VerifyPackage(o.path, &report);
  } else {
    throw core::Error((o.path / "manifest.json").string() +
                      ": field 'format': expected \"mesocap.session\" or \"mesocap.material\"" +
                      (format.empty() ? std::string(" (no manifest.json)") : ", got " + core::Quoted(format)));
  }
  return report;
}

}  // namespace mesocap::pipelines
