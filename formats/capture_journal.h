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
#include <set>
#include <string>
#include <vector>

#include "formats/capture_session.h"

namespace mesocap::formats {

struct JournalFile {
  std::string path;  // inside the session folder; IsSessionPath
  std::uint64_t bytes = 0;
};

struct JournalRecord {
  std::uint64_t seq = 0;  // 0, 1, 2, ... in file order
  std::string step;       // a plan step id, each at most once
  std::string time_utc;   // when the step completed; UtcTimestamp()
  std::vector<JournalFile> files;
};

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
// be in its plan.
JournalContents ReadCaptureJournal(const std::filesystem::path& file,
                                   const SessionManifest* manifest = nullptr);

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
  // Bytes of a torn tail truncated when opening; 0 if none.
  std::uint64_t dropped_bytes() const { return dropped_bytes_; }

  // Checks the record (seq == next_seq(), a new step of the plan, valid time
  // and paths; each file exists with that size), fsyncs its files and their
  // folders, then appends and fsyncs the record. Throws Error and leaves the
  // journal as it was on any failure; after a failed write or fsync the
  // object refuses further appends (reopen to recover).
  void Append(const JournalRecord& record);

 private:
  void Check(const JournalRecord& record) const;

  std::filesystem::path file_;
  int fd_ = -1;
  std::vector<JournalRecord> records_;
  std::set<std::string> done_;
  std::set<std::string> plan_;  // empty: any step id
  bool has_plan_ = false;
  std::uint64_t size_ = 0;
  std::uint64_t dropped_bytes_ = 0;
  bool broken_ = false;
};

}  // namespace mesocap::formats
