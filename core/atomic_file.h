// Atomic replacement of files and folders: write under a temporary name in the
// same folder, then rename (DESIGN.md "On disk"). A reader never sees a half
// written file, and a crash or an error never destroys what was there before.
#pragma once

#include <filesystem>
#include <string_view>

#include <nlohmann/json_fwd.hpp>

namespace mesocap::core {

// A file being written. Write to temp_path(); Commit() syncs it and renames it
// over the target. Destroyed without Commit(), it removes the temporary file.
// The temporary name keeps the target's extension, so writers that choose a
// codec by extension (OpenImageIO) pick the right one.
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

// A folder being written (a material package, an exported database). Fill
// temp_path(); Commit() renames it to the target. An existing target is an
// error unless `replace` is set, in which case the old folder is moved aside
// and removed only after the new one is in place.
class AtomicDirectory {
 public:
  AtomicDirectory(std::filesystem::path target, bool replace);
  ~AtomicDirectory();
  AtomicDirectory(const AtomicDirectory&) = delete;
  AtomicDirectory& operator=(const AtomicDirectory&) = delete;

  const std::filesystem::path& temp_path() const { return temp_; }
  void Commit();

 private:
  std::filesystem::path target_;
  std::filesystem::path temp_;
  bool replace_;
  bool committed_ = false;
};

void WriteTextFileAtomically(const std::filesystem::path& target, std::string_view contents);
// Pretty-printed (2-space indent) JSON with a trailing newline.
void WriteJsonFileAtomically(const std::filesystem::path& target, const nlohmann::json& value);

// Whether `name` is a temporary name that AtomicFile or AtomicDirectory
// makes (".stem.tmp-PID-N.ext", ".name.tmp-PID-N", ".name.old.tmp-PID-N").
bool IsAtomicTemporaryName(std::string_view name);
// Removes what AtomicFile / AtomicDirectory left behind under `dir`
// (recursively) when a process died mid-write; returns how many entries it
// removed. Only for a folder no other process is writing (a locked capture
// session), since it cannot tell a dead writer's file from a live one's.
std::size_t RemoveStaleTemporaries(const std::filesystem::path& dir);

// fsync of a file or folder by path; throws Error on failure.
void SyncPath(const std::filesystem::path& path);

}  // namespace mesocap::core
