#include "formats/captured_session.h"

#include <fcntl.h>
#include <fnmatch.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/error.h"
#include "formats/capture_plan_steps.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
namespace {

bool Allowed(const std::string& step, const std::vector<std::string>& patterns) {
  for (const std::string& p : patterns) {
    if (p == step || ::fnmatch(p.c_str(), step.c_str(), 0) == 0) return true;
  }
  return false;
}

std::string Listed(const std::vector<std::string>& steps, std::size_t max_shown = 3) {
  std::string text;
  for (std::size_t i = 0; i < steps.size() && i < max_shown; ++i) text += (i ? ", " : "") + steps[i];
  if (steps.size() > max_shown) text += ", ... (" + std::to_string(steps.size() - max_shown) + " more)";
  return text;
}

// Why a journaled file no longer matches its record; empty when it does.
// Version 1 sessions recorded sizes only.
std::string JournalFileProblem(const fs::path& dir, const JournalFile& f) {
  if (f.xxh3) return core::ChecksumProblem(dir / f.path, {f.bytes, *f.xxh3});
  std::error_code ec;
  const auto size = fs::file_size(dir / f.path, ec);
  if (ec) return "missing or not a regular file";
  if (size != f.bytes) return "is " + std::to_string(size) + " bytes, expected " + std::to_string(f.bytes);
  return {};
}

}  // namespace

CapturedSession::CapturedSession(fs::path dir, const SessionOpenOptions& options)
    : dir_(std::move(dir)), manifest_(ReadSessionManifest(dir_)) {
  CheckPlanSteps(manifest_, manifest_file());
  const fs::path journal = dir_ / kSessionJournalName;
  if (JournalExists(journal)) {
    lock_fd_ = ::open(journal.c_str(), O_RDONLY | O_CLOEXEC);
    if (lock_fd_ < 0) throw core::Error(journal.string() + ": cannot open: " + std::strerror(errno));
    if (::flock(lock_fd_, LOCK_SH | LOCK_NB) != 0) {
      ::close(lock_fd_);
      throw core::Error(dir_.string() + ": the session is being written (a capture holds its journal); " +
                        options.command + " can read it once the capture has finished or stopped");
    }
    try {
      records_ = ReadCaptureJournal(journal, &manifest_).records;
    } catch (...) {
      ::close(lock_fd_);
      throw;
    }
  }
  latest_ = LatestRecords(records_);
  for (const auto& [step, record] : latest_) {
    for (const JournalFile& f : record->files) files_[f.path] = &f;
  }
  std::vector<std::string> refused;
  for (const PlannedStep& step : manifest_.plan) {
    if (latest_.count(step.id)) continue;
    (Allowed(step.id, options.allow_incomplete) ? missing_ : refused).push_back(step.id);
  }
  if (!refused.empty()) {
    if (lock_fd_ >= 0) ::close(lock_fd_);
    throw core::Error(dir_.string() + ": incomplete session: " + std::to_string(latest_.size()) + " of " +
                      std::to_string(manifest_.plan.size()) + " steps done (missing " + Listed(refused) +
                      "); finish it with `mesocap simulate --resume` (or capture), or name the steps to skip with "
                      "--allow-incomplete");
  }
}

CapturedSession::~CapturedSession() {
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

std::optional<core::FileChecksum> CapturedSession::RecordedChecksum(const std::string& path) const {
  const auto it = files_.find(path);
  if (it == files_.end()) {
    throw core::FormatError(dir_ / kSessionJournalName, "files",
                            "no record of a done step lists " + core::Quoted(path) + ", which the plan names");
  }
  if (!it->second->xxh3) return std::nullopt;
  return core::FileChecksum{it->second->bytes, *it->second->xxh3};
}

fs::path CapturedSession::IntactFile(const std::string& path) const {
  const auto it = files_.find(path);
  if (it == files_.end()) {
    throw core::FormatError(dir_ / kSessionJournalName, "files",
                            "no record of a done step lists " + core::Quoted(path) + ", which the plan names");
  }
  const fs::path file = dir_ / path;
  if (const std::string problem = JournalFileProblem(dir_, *it->second); !problem.empty()) {
    throw core::FormatError(file, "checksum", problem);
  }
  return file;
}

fs::path CapturedSession::IntactCalibrationFile() const {
  if (!manifest_.calibration) {
    throw core::Error(manifest_file().string() + ": the session names no calibration; give --calibration");
  }
  const fs::path file = dir_ / *manifest_.calibration;
  if (manifest_.calibration_checksum) core::ExpectFileChecksum(file, *manifest_.calibration_checksum);
  return file;
}

std::vector<DamagedFile> DamagedSessionFiles(const fs::path& dir, const SessionManifest& manifest,
                                             const std::vector<JournalRecord>& records) {
  std::vector<DamagedFile> damaged;
  if (manifest.calibration && manifest.calibration_checksum) {
    const std::string problem = core::ChecksumProblem(dir / *manifest.calibration, *manifest.calibration_checksum);
    if (!problem.empty()) damaged.push_back({"", *manifest.calibration, problem});
  }
  for (const auto& [step, record] : LatestRecords(records)) {
    for (const JournalFile& f : record->files) {
      const std::string problem = JournalFileProblem(dir, f);
      if (!problem.empty()) damaged.push_back({step, f.path, problem});
    }
  }
  return damaged;
}

}  // namespace mesocap::formats
