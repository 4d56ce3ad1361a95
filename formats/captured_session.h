// A capture session opened for processing (`process mdf`, `process btf`,
// `verify`): its manifest and journal as they stand, a shared lock on the
// journal for as long as it is open (so no capture writes the session while
// it is read, and a session being written is refused), and its files handed
// out only after their size and hash match what the journal recorded.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/file_checksum.h"
#include "formats/capture_journal.h"
#include "formats/capture_session.h"

namespace mesocap::formats {

struct SessionOpenOptions {
  // Steps of the plan that may be missing from the journal: step ids or
  // shell patterns ("btf-t3_*"; "*" allows any). Empty: the session must be
  // complete.
  std::vector<std::string> allow_incomplete;
  // The command that processes it, for messages ("process btf").
  std::string command = "processing";
};

class CapturedSession {
 public:
  // Reads and checks the manifest and journal. Throws Error when another
  // process holds the journal for writing ("being written"), and when
  // steps are missing that `allow_incomplete` does not name ("N of M steps
  // done; finish it with simulate --resume (or capture)").
  explicit CapturedSession(std::filesystem::path dir, const SessionOpenOptions& options = {});
  ~CapturedSession();
  CapturedSession(const CapturedSession&) = delete;
  CapturedSession& operator=(const CapturedSession&) = delete;

  const std::filesystem::path& dir() const { return dir_; }
  const SessionManifest& manifest() const { return manifest_; }
  std::filesystem::path manifest_file() const { return dir_ / kSessionManifestName; }
  bool IsDone(const std::string& step) const { return latest_.count(step) > 0; }
  // Plan steps the journal lacks (allowed by the options), in plan order.
  const std::vector<std::string>& missing_steps() const { return missing_; }
  std::size_t done_steps() const { return latest_.size(); }

  // dir()/path after checking its size and hash against the journal record
  // of the step that wrote it (size only for a version 1 session). Throws
  // FormatError naming the file when it differs, Error when no done step
  // wrote that path.
  std::filesystem::path IntactFile(const std::string& path) const;
  // Whether a done step's journal record lists `path`.
  bool Journaled(const std::string& path) const { return files_.count(path) > 0; }
  // The size and hash the journal records for `path`, to check when it is
  // read (nullopt in a version 1 session); Error when no done step wrote it.
  std::optional<core::FileChecksum> RecordedChecksum(const std::string& path) const;
  // The calibration the manifest names, checked the same way; Error when
  // the manifest names none.
  std::filesystem::path IntactCalibrationFile() const;

 private:
  std::filesystem::path dir_;
  SessionManifest manifest_;
  std::vector<JournalRecord> records_;
  std::map<std::string, const JournalRecord*> latest_;  // step -> record that counts
  std::map<std::string, const JournalFile*> files_;     // path -> its entry in a latest record
  std::vector<std::string> missing_;
  int lock_fd_ = -1;
};

struct DamagedFile {
  std::string step;  // the step whose latest record lists it; empty for the manifest's calibration
  std::string path;  // inside the session
  std::string problem;
};

// The files of a session whose contents differ from what its manifest and
// journal record (missing, another size, another hash); empty when all are
// intact. Reads every file; takes no lock.
std::vector<DamagedFile> DamagedSessionFiles(const std::filesystem::path& dir, const SessionManifest& manifest,
                                             const std::vector<JournalRecord>& records);

}  // namespace mesocap::formats
