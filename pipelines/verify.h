// The integrity check (`mesocap verify PATH`): every data file of a capture
// session or material package against the size and XXH3 hash its journal or
// manifest recorded when it was written, plus the manifest's and journal's
// own validation. Names every damaged file; reads every byte once.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/error.h"
#include "formats/capture_session.h"

namespace mesocap::pipelines {

struct VerifyOptions {
  std::filesystem::path path;  // a capture session or material package folder

  core::CheckResult Check() const;
};

struct VerifyReport {
  std::string kind;  // "capture session" or "material package"
  int version = 0;   // of its manifest; version 1 has no checksums to check
  std::size_t files_checked = 0;
  std::uint64_t bytes_checked = 0;
  // A file that differs from its record: its path inside the folder and why.
  struct Damage {
    std::string file;
    std::string problem;
  };
  std::vector<Damage> damaged;
  // A capture session's plan steps the journal does not hold yet (not
  // damage: `simulate --resume` or a capture completes them).
  std::size_t steps_planned = 0;
  std::size_t steps_done = 0;
  std::uint64_t torn_journal_bytes = 0;  // an interrupted append, dropped on the next resume
};

// What a reader checks in a session's manifest beyond its format: every
// step against the session's rig (formats::CheckPlanSteps) and the rig's
// calibration board. FormatError naming the file and the field.
void CheckSessionManifest(const formats::SessionManifest& manifest, const std::filesystem::path& manifest_file);

// Throws Error when `path` holds neither a session nor a package, or when
// its manifest or journal is itself invalid (naming the field); a damaged
// data file is reported, not thrown, so that every one is named.
VerifyReport RunVerify(const VerifyOptions& options);

}  // namespace mesocap::pipelines
