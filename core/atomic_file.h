// Atomic replacement of files and folders: write under a temporary name in the
// same folder, then rename (docs/ARCHITECTURE.md "On disk"). A reader never sees a half
// written file, and a crash or an error never destroys what was there before.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace mesocap::core {

// A file being written. Write to temp_path(); Commit() syncs it and renames it
// over the target. Destroyed without Commit(), it removes the temporary file.
// The temporary name keeps the target's extension, so writers that choose a
// codec by extension (OpenImageIO) pick the right one.
// "; no space left on the device (N bytes free)" when the file system that
// holds `path` (or its nearest existing folder) has less than 1 MiB free,
// so that a failed write says why; empty otherwise.
std::string FullDiskNote(const std::filesystem::path& path);

class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path target);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::filesystem::path& temp_path() const { return temp_; }
  const std::filesystem::path& target() const { return target_; }
  void Commit();

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  bool committed_ = false;
};

// When a command's output (a folder or a file) exists: what it may replace.
// A command's --replace never removes anything but what that command writes
// (a material package, an exported database), and never its own input.
struct OutputReplacement {
  bool allowed = false;  // the user asked for it (--replace)
  std::string kind;      // what the command writes, for messages: "a material package"
  // Whether an existing output holds `kind`; required when `allowed`.
  std::function<bool(const std::filesystem::path&)> holds_kind;
  // The command's inputs: neither they nor a folder holding one is replaced.
  std::vector<std::filesystem::path> inputs;
};

// Throws Error naming `target` when the folder it goes in does not exist:
// checked before a command works, not when it writes.
void ExpectOutputFolder(const std::filesystem::path& target);

// Throws Error naming `target` and what is there unless `target` does not
// exist, or `replacement` allows replacing what it holds.
void ExpectReplaceable(const std::filesystem::path& target, const OutputReplacement& replacement);

// A folder being written (a material package, an exported database). Fill
// temp_path(); Commit() renames it to the target. An existing target must
// pass ExpectReplaceable; it is swapped out in one atomic rename and removed
// only after the new folder is in place. Creating one first removes the
// temporaries a killed writer of the same target left beside it.
class AtomicDirectory {
 public:
  AtomicDirectory(std::filesystem::path target, const OutputReplacement& replacement);
  ~AtomicDirectory();
  AtomicDirectory(const AtomicDirectory&) = delete;
  AtomicDirectory& operator=(const AtomicDirectory&) = delete;

  const std::filesystem::path& temp_path() const { return temp_; }
  void Commit();

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  OutputReplacement replacement_;
  bool existed_ = false;
  bool committed_ = false;
};

// Writes `contents` (any bytes) to a temporary name, syncs it and renames
// it to `target`; a write cut short (a full disk) throws Error naming the
// target, and `target` keeps what it held.
void WriteTextFileAtomically(const std::filesystem::path& target, std::string_view contents);
// Pretty-printed (2-space indent) JSON with a trailing newline.
void WriteJsonFileAtomically(const std::filesystem::path& target, const nlohmann::json& value);

// Whether `name` is a temporary name that AtomicFile or AtomicDirectory
// makes (".stem.tmp-PID-N.ext", ".name.tmp-PID-N", ".name.old.tmp-PID-N").
bool IsAtomicTemporaryName(std::string_view name);
// Removes the temporaries that writers of `target` (AtomicFile or
// AtomicDirectory) left beside it when they were killed: only names made
// for this target, and only those whose writing process is gone. A folder
// that was moved aside to be replaced comes back when the target is
// missing. Returns how many entries it removed or restored.
std::size_t RemoveStaleTemporariesOf(const std::filesystem::path& target);
// Removes what AtomicFile / AtomicDirectory left behind under `dir`
// (recursively) when a process died mid-write; returns how many entries it
// removed. Only for a folder no other process is writing (a locked capture
// session), since it cannot tell a dead writer's file from a live one's.
std::size_t RemoveStaleTemporaries(const std::filesystem::path& dir);

// fsync of a file or folder by path; throws Error on failure.
void SyncPath(const std::filesystem::path& path);

}  // namespace mesocap::core
