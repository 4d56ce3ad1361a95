#include "formats/capture_journal.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <utility>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/file_checksum.h"
#include "core/json_field_reader.h"
#include "formats/calibration.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

// A valid record nests 3 levels (record, files, file).
constexpr int kJournalMaxDepth = 8;
constexpr std::int64_t kMaxFileBytes = std::int64_t{1} << 62;
constexpr std::int64_t kMaxSeq = std::int64_t{1} << 53;

std::string LineName(std::uint64_t line_number) { return "line " + std::to_string(line_number); }

std::string SystemError() { return std::strerror(errno); }

json RecordJson(const JournalRecord& r) {
  json files = json::array();
  for (const auto& f : r.files) {
    json entry = {{"path", f.path}, {"bytes", f.bytes}};
    if (f.xxh3) entry["xxh3_64"] = core::ChecksumText(*f.xxh3);
    files.push_back(std::move(entry));
  }
  json record = {{"seq", r.seq}, {"step", r.step}, {"time_utc", r.time_utc}, {"files", std::move(files)}};
  if (r.replaces) record["replaces"] = *r.replaces;
  return record;
}

// One record's own content; `where` names its line.
using Hashes = JournalHashes;

Hashes HashesOf(const SessionManifest* manifest) {
  if (!manifest) return Hashes::kEither;
  return manifest->version >= 2 ? Hashes::kRequired : Hashes::kAbsent;
}

JournalRecord ParseRecord(const json& document, const fs::path& file, const std::string& where, Hashes hashes) {
  core::RejectDeepNesting(document, file, kJournalMaxDepth, where);
  const core::JsonFieldReader fields(document, file, where);
  fields.RejectUnknownMembers({"seq", "step", "time_utc", "files", "replaces"});
  JournalRecord r;
  r.seq = static_cast<std::uint64_t>(fields.Integer("seq", 0, kMaxSeq));
  if (fields.Has("replaces")) {
    r.replaces = static_cast<std::uint64_t>(fields.Integer("replaces", 0, static_cast<std::int64_t>(r.seq) - 1));
  }
  r.step = fields.String("step");
  if (!IsValidId(r.step)) {
    fields.Fail("step", "expected a step id (1 to 128 characters from A-Z a-z 0-9 . _ -)");
  }
  r.time_utc = fields.String("time_utc");
  if (!IsUtcTimestamp(r.time_utc)) {
    fields.Fail("time_utc", "expected an ISO 8601 UTC time such as 2025-06-01T12:34:56Z");
  }
  std::set<std::string> paths;
  for (const auto& f : fields.Objects("files", kMaxFilesPerRecord)) {
    if (hashes == Hashes::kAbsent) {
      f.RejectUnknownMembers({"path", "bytes"});  // version 1: sizes only
    } else {
      f.RejectUnknownMembers({"path", "bytes", "xxh3_64"});
    }
    JournalFile jf;
    jf.path = f.String("path");
    if (!IsSessionPath(jf.path)) {
      f.Fail("path",
             "expected a relative path inside the session folder (no \"..\", no "
             "leading '/', no empty parts)");
    }
    if (!paths.insert(jf.path).second) f.Fail("path", "listed twice in this record");
    if (hashes == Hashes::kRequired || (hashes == Hashes::kEither && f.Has("xxh3_64"))) {
      const core::FileChecksum sum = ReadChecksum(f);
      jf.bytes = sum.bytes;
      jf.xxh3 = sum.xxh3;
    } else {
      jf.bytes = static_cast<std::uint64_t>(f.Integer("bytes", 0, kMaxFileBytes));
    }
    r.files.push_back(std::move(jf));
  }
  return r;
}

// How the journal so far constrains the next record.
struct JournalState {
  std::uint64_t next_seq = 0;
  const std::map<std::string, std::uint64_t>* last_seq = nullptr;  // step -> its latest record
  const std::set<std::string>* plan = nullptr;                     // null: any step id
};

// Throws FormatError when `r` cannot be the next record.
void CheckOrder(const JournalRecord& r, const JournalState& state, const fs::path& file, const std::string& where) {
  if (r.seq != state.next_seq) {
    throw core::FormatError(file, where + ".seq",
                            "expected " + std::to_string(state.next_seq) +
                                " (records are numbered "
                                "0, 1, 2, ... in order), got " +
                                std::to_string(r.seq));
  }
  const auto last = state.last_seq->find(r.step);
  if (last != state.last_seq->end() && r.replaces != last->second) {
    throw core::FormatError(file, where + ".step",
                            "step \"" + r.step + "\" is already recorded (line " + std::to_string(last->second + 1) +
                                "); a record that does it again says \"replaces\": " + std::to_string(last->second));
  }
  if (last == state.last_seq->end() && r.replaces) {
    throw core::FormatError(file, where + ".replaces", "step \"" + r.step + "\" has no earlier record to replace");
  }
  if (state.plan && !state.plan->count(r.step)) {
    throw core::FormatError(file, where + ".step", "step \"" + r.step + "\" is not in the plan");
  }
}

std::set<std::string> PlanIds(const SessionManifest& manifest) {
  std::set<std::string> ids;
  for (const auto& step : manifest.plan) ids.insert(step.id);
  return ids;
}

// Splits the first `size` bytes of `file` into lines and hands each complete
// one to `on_line(text, overlong, end_offset)`; bytes after the last newline
// are left out. Lines longer than kMaxJournalLineBytes arrive empty with
// `overlong` set, so a hostile file cannot make it allocate much.
template <typename OnLine>
void ForEachLine(const fs::path& file, std::uint64_t size, OnLine on_line) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw core::FormatError(file, "", "cannot open for reading");
  std::vector<char> chunk(1 << 16);
  std::string line;
  bool overlong = false;
  std::uint64_t offset = 0;
  while (offset < size) {
    const auto n = static_cast<std::size_t>(std::min<std::uint64_t>(chunk.size(), size - offset));
    in.read(chunk.data(), static_cast<std::streamsize>(n));
    if (static_cast<std::size_t>(in.gcount()) != n) throw core::FormatError(file, "", "short read");
    std::size_t start = 0;
    while (start < n) {
      const char* newline = static_cast<const char*>(std::memchr(chunk.data() + start, '\n', n - start));
      const std::size_t end = newline ? static_cast<std::size_t>(newline - chunk.data()) : n;
      if (!overlong && line.size() + (end - start) <= kMaxJournalLineBytes) {
        line.append(chunk.data() + start, end - start);
      } else {
        overlong = true;
        line.clear();
      }
      if (!newline) break;
      on_line(line, overlong, offset + end + 1);
      line.clear();
      overlong = false;
      start = end + 1;
    }
    offset += n;
  }
}

}  // namespace

bool JournalExists(const fs::path& file) {
  std::error_code ec;
  return fs::symlink_status(file, ec).type() != fs::file_type::not_found;
}

JournalContents ReadCaptureJournal(const fs::path& file, const SessionManifest* manifest) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    throw core::FormatError(file, "", ec ? "cannot read: " + ec.message() : std::string("not a regular file"));
  }
  // Read only what is there now: a writer may be appending while we read.
  const std::uint64_t size = fs::file_size(file, ec);
  if (ec) throw core::FormatError(file, "", "cannot read size: " + ec.message());
  if (size > kMaxJournalBytes) {
    throw core::FormatError(
        file, "",
        "file is " + std::to_string(size) + " bytes; at most " + std::to_string(kMaxJournalBytes) + " expected");
  }
  const std::set<std::string> plan = manifest ? PlanIds(*manifest) : std::set<std::string>();
  std::map<std::string, std::uint64_t> last_seq;
  JournalContents contents;
  std::uint64_t line_number = 0;

  const auto on_line = [&](const std::string& text, bool overlong, std::uint64_t end) {
    ++line_number;
    const std::string where = LineName(line_number);
    // A line that is not JSON can only be the remains of an interrupted
    // append when nothing follows it.
    const bool last = end == size;
    if (overlong) {
      if (last) return;
      throw core::FormatError(file, where, "longer than " + std::to_string(kMaxJournalLineBytes) + " bytes");
    }
    const json document = json::parse(text, nullptr, /*allow_exceptions=*/false);
    if (document.is_discarded()) {
      if (last) return;
      throw core::FormatError(file, where, "not valid JSON");
    }
    JournalRecord r = ParseRecord(document, file, where, HashesOf(manifest));
    CheckOrder(r, {contents.records.size(), &last_seq, manifest ? &plan : nullptr}, file, where);
    last_seq[r.step] = r.seq;
    contents.records.push_back(std::move(r));
    contents.intact_bytes = end;
  };
  ForEachLine(file, size, on_line);
  // Everything after the last good record is a torn tail.
  contents.dropped_bytes = size - contents.intact_bytes;
  return contents;
}

CaptureJournal::CaptureJournal(fs::path file, const SessionManifest* manifest) : file_(std::move(file)) {
  bool created = true;
  fd_ = ::open(file_.c_str(), O_RDWR | O_APPEND | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd_ < 0 && errno == EEXIST) {
    created = false;
    fd_ = ::open(file_.c_str(), O_RDWR | O_APPEND | O_CLOEXEC);
  }
  if (fd_ < 0) throw core::Error(file_.string() + ": cannot open journal: " + SystemError());
  try {
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      throw core::Error(file_.string() + ": journal is open in another process (" + SystemError() + ")");
    }
    if (created) {
      // The new file's entry in the session folder must survive a crash too.
      if (::fsync(fd_) != 0) throw core::Error(file_.string() + ": fsync failed: " + SystemError());
      core::SyncPath(file_.has_parent_path() ? file_.parent_path() : fs::path("."));
    }
    JournalContents contents = ReadCaptureJournal(file_, manifest);
    if (contents.dropped_bytes > 0) {
      // Cut the torn tail so the next record starts on a line of its own.
      if (::ftruncate(fd_, static_cast<off_t>(contents.intact_bytes)) != 0 || ::fsync(fd_) != 0) {
        throw core::Error(file_.string() + ": cannot truncate the torn last line: " + SystemError());
      }
    }
    records_ = std::move(contents.records);
    for (const auto& r : records_) {
      done_.insert(r.step);
      last_seq_[r.step] = r.seq;
    }
    if (manifest) {
      plan_ = PlanIds(*manifest);
      has_plan_ = true;
      hashes_ = HashesOf(manifest);
    }
    size_ = contents.intact_bytes;
    dropped_bytes_ = contents.dropped_bytes;
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

CaptureJournal::~CaptureJournal() { ::close(fd_); }

void CaptureJournal::Check(const JournalRecord& record) const {
  const std::string where = LineName(records_.size() + 1);
  ParseRecord(RecordJson(record), file_, where, hashes_);
  if (done_.count(record.step)) {
    throw core::FormatError(file_, where + ".step", "step \"" + record.step + "\" is already done");
  }
  CheckOrder(record, {records_.size(), &last_seq_, has_plan_ ? &plan_ : nullptr}, file_, where);
}

void CaptureJournal::Redo(const std::string& step) {
  const auto last = last_seq_.find(step);
  if (last == last_seq_.end()) throw core::Error(file_.string() + ": step \"" + step + "\" was never recorded");
  done_.erase(step);
  redo_[step] = last->second;
}

void CaptureJournal::Append(const JournalRecord& given) {
  if (broken_) {
    throw core::Error(file_.string() + ": an earlier append failed; reopen the journal to go on");
  }
  JournalRecord record = given;
  if (const auto redo = redo_.find(record.step); redo != redo_.end()) record.replaces = redo->second;
  const fs::path session_dir = file_.has_parent_path() ? file_.parent_path() : fs::path(".");
  for (JournalFile& f : record.files) {
    if (hashes_ != Hashes::kAbsent && !f.xxh3 && IsSessionPath(f.path)) {
      std::error_code ec;
      if (fs::is_regular_file(session_dir / f.path, ec)) f.xxh3 = core::ComputeFileChecksum(session_dir / f.path).xxh3;
    }
  }
  Check(record);

  // The record promises these files are on disk: make it true first.
  const fs::path session = file_.has_parent_path() ? file_.parent_path() : fs::path(".");
  std::set<fs::path> folders;
  for (const auto& f : record.files) {
    const fs::path path = session / f.path;
    std::error_code ec;
    const bool regular = fs::is_regular_file(path, ec);
    const auto bytes = regular ? fs::file_size(path, ec) : 0;
    if (!regular || ec || bytes != f.bytes) {
      throw core::Error(file_.string() + ": step \"" + record.step + "\": file " + f.path +
                        (regular
                             ? " has " + std::to_string(bytes) + " bytes, the record says " + std::to_string(f.bytes)
                             : " is missing or not a regular file"));
    }
    core::SyncPath(path);
    folders.insert(path.parent_path());
  }
  for (const auto& folder : folders) core::SyncPath(folder);

  std::string line;
  try {
    line = RecordJson(record).dump() + "\n";
  } catch (const json::exception& e) {  // a path that is not UTF-8
    throw core::Error(file_.string() + ": step \"" + record.step + "\": cannot write record: " + e.what());
  }
  // Never write what the reader would refuse.
  if (line.size() > kMaxJournalLineBytes) {
    throw core::Error(file_.string() + ": step \"" + record.step + "\": record is longer than " +
                      std::to_string(kMaxJournalLineBytes) + " bytes");
  }
  if (size_ + line.size() > kMaxJournalBytes) {
    throw core::Error(file_.string() + ": journal would exceed " + std::to_string(kMaxJournalBytes) + " bytes");
  }

  std::size_t written = 0;
  while (written < line.size()) {
    const ssize_t n = ::write(fd_, line.data() + written, line.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = n < 0 ? SystemError() : "nothing written";
      // Take back a partial line; if even that fails, the tail is torn and
      // only reopening (which truncates it) can go on.
      if (::ftruncate(fd_, static_cast<off_t>(size_)) != 0) broken_ = true;
      throw core::Error(file_.string() + ": cannot append record: " + why);
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fsync(fd_) != 0) {
    broken_ = true;
    throw core::Error(file_.string() + ": fsync failed; step \"" + record.step +
                      "\" is not recorded as done: " + SystemError());
  }
  size_ += line.size();
  records_.push_back(record);
  done_.insert(record.step);
  last_seq_[record.step] = record.seq;
  redo_.erase(record.step);
}

std::map<std::string, const JournalRecord*> LatestRecords(const std::vector<JournalRecord>& records) {
  std::map<std::string, const JournalRecord*> latest;
  for (const JournalRecord& r : records) latest[r.step] = &r;
  return latest;
}

}  // namespace mesocap::formats
