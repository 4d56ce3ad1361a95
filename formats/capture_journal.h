// The append-only journal of a capture session's completed steps
// (docs/FORMATS.md "Capture journal"): JSON lines, one record per step.
//
// Durability: Append() makes the step's files durable, then writes the
// record in one write() and fsyncs; the step counts as done only once that
// returns. So after any crash the journal holds complete records plus at
// most one torn last line, which readers drop and the next writer truncates.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "formats/capture_session.h"

namespace mesocap::formats {

struct JournalFile {
  std::string path;  // inside the session folder; IsSessionPath
  std::uint64_t bytes = 0;
  // XXH3-64 of the contents; required in a version 2 session (the writer
  // fills it in when it is missing), absent in version 1.
  std::optional<std::uint64_t> xxh3 = std::nullopt;
};

struct JournalRecord {
  std::uint64_t seq = 0;  // 0, 1, 2, ... in file order
  std::string step;       // a plan step id
  std::string time_utc;   // when the step completed; UtcTimestamp()
  std::vector<JournalFile> files;
  // A step done again (its files were found damaged) names the seq of the
  // record it supersedes; the latest record of a step is the one that counts.
  std::optional<std::uint64_t> replaces = std::nullopt;
};

// Whether records carry file hashes: a version 2 session's must, a version 1
// session's cannot, and without the manifest either is read.
enum class JournalHashes { kRequired, kAbsent, kEither };

inline constexpr std::size_t kMaxJournalLineBytes = 1 << 20;
inline constexpr std::size_t kMaxFilesPerRecord = 65536;
inline constexpr std::uintmax_t kMaxJournalBytes = 1ull << 30;

struct JournalContents {
  std::vector<JournalRecord> records;
  std::uint64_t intact_bytes = 0;   // length of the prefix holding `records`
  std::uint64_t dropped_bytes = 0;  // a torn last line that was ignored; 0 if none
};

// Reads and validates a journal. A torn last line (no final newline, or not
// JSON) is dropped and counted; anything else wrong, in any line, throws
// FormatError naming the file and "line N". With a manifest, every step must
// be in its plan, and a version 2 session's files must carry their hash.
JournalContents ReadCaptureJournal(const std::filesystem::path& file, const SessionManifest* manifest = nullptr);

// Whether a session has a journal: anything at `file` counts, a dangling or
// looping link too, so that reading it reports what is wrong instead of the
// session reading as one with no step done.
bool JournalExists(const std::filesystem::path& file);

// The latest record of each step (what counts), by step id.
std::map<std::string, const JournalRecord*> LatestRecords(const std::vector<JournalRecord>& records);

// The journal of a running capture, open for appending. Opening creates the
// file if needed, takes an exclusive lock (one writer per session) and
// truncates a torn tail so new records never follow garbage.
class CaptureJournal {
 public:
  // The session folder is file's parent; record file paths are relative to it.
  explicit CaptureJournal(std::filesystem::path file, const SessionManifest* manifest = nullptr);
  ~CaptureJournal();
  CaptureJournal(const CaptureJournal&) = delete;
  CaptureJournal& operator=(const CaptureJournal&) = delete;

  // Records so far, including those appended through this object.
  const std::vector<JournalRecord>& records() const { return records_; }
  std::uint64_t next_seq() const { return records_.size(); }
  bool IsDone(const std::string& step) const { return done_.count(step) > 0; }
  // Marks a done step as to be done again (its files were found damaged):
  // IsDone turns false, and its next Append supersedes the old record.
  void Redo(const std::string& step);
  // Bytes of a torn tail truncated when opening; 0 if none.
  std::uint64_t dropped_bytes() const { return dropped_bytes_; }

  // Checks the record (seq == next_seq(), a new step of the plan or one
  // marked Redo, valid time and paths; each file exists with that size),
  // hashes files that lack their hash, fsyncs them and their folders, then
  // appends and fsyncs the record. Throws Error and leaves the
  // journal as it was on any failure; after a failed write or fsync the
  // object refuses further appends (reopen to recover).
  void Append(const JournalRecord& record);

 private:
  void Check(const JournalRecord& record) const;
  std::map<std::string, std::uint64_t> last_seq_;  // step -> seq of its latest record

  std::filesystem::path file_;
  int fd_ = -1;
  std::vector<JournalRecord> records_;
  std::set<std::string> done_;
  std::map<std::string, std::uint64_t> redo_;  // step -> seq of the record a new one replaces
  JournalHashes hashes_ = JournalHashes::kEither;
  std::set<std::string> plan_;  // empty: any step id
  bool has_plan_ = false;
  std::uint64_t size_ = 0;
  std::uint64_t dropped_bytes_ = 0;
  bool broken_ = false;
};

}  // namespace mesocap::formats
