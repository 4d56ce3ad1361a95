#include "core/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <spdlog/spdlog.h>
#include <stdio.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "core/error.h"

namespace mesocap::core {
namespace fs = std::filesystem;
namespace {

// Unique within the process (counter) and across processes (pid).
std::string TemporarySuffix() {
  static std::atomic<unsigned> counter{0};
  return ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

fs::path ParentOrDot(const fs::path& p) { return p.has_parent_path() ? p.parent_path() : fs::path("."); }

// "out/" names the folder "out".
fs::path WithoutTrailingSlash(fs::path p) { return p.filename().empty() ? p.parent_path() : p; }

// The writer's process id when `name` is "." + base + ".tmp-PID-N" + ext.
std::optional<long> TemporaryWriterPid(std::string_view name, std::string_view base, std::string_view ext) {
  const std::string prefix = "." + std::string(base) + ".tmp-";
  if (name.size() <= prefix.size() + ext.size() || name.substr(0, prefix.size()) != prefix) return std::nullopt;
  if (name.substr(name.size() - ext.size()) != ext) return std::nullopt;
  const std::string_view rest = name.substr(prefix.size(), name.size() - prefix.size() - ext.size());
  const std::size_t dash = rest.find('-');
  if (dash == std::string_view::npos || dash == 0 || dash + 1 == rest.size()) return std::nullopt;
  long pid = 0;
  const auto [end, ec] = std::from_chars(rest.data(), rest.data() + dash, pid);
  if (ec != std::errc() || end != rest.data() + dash || pid <= 0) return std::nullopt;
  for (const char c : rest.substr(dash + 1)) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return std::nullopt;
  }
  return pid;
}

// A process id that no longer exists. A pid the system gave to another
// process since keeps its temporaries until that process ends too: never a
// live writer's file removed.
bool ProcessIsGone(long pid) { return ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH; }

// Whether `a` is `b` or a folder holding it.
bool Holds(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  const fs::path outer = fs::weakly_canonical(a, ec);
  if (ec) return false;
  const fs::path inner = fs::weakly_canonical(b, ec);
  if (ec) return false;
  auto i = inner.begin();
  for (auto o = outer.begin(); o != outer.end(); ++o) {
    if (o->empty()) continue;  // a trailing separator
    if (i == inner.end() || *o != *i) return false;
    ++i;
  }
  return true;
}

}  // namespace

void ExpectOutputFolder(const fs::path& target) {
  const fs::path folder = ParentOrDot(WithoutTrailingSlash(target));
  std::error_code ec;
  if (!fs::is_directory(folder, ec))
    throw Error(target.string() + ": no folder " + folder.string() + " to write it in");
}

void ExpectReplaceable(const fs::path& target_in, const OutputReplacement& r) {
  const fs::path target = WithoutTrailingSlash(target_in);
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(target, ec))) return;
  for (const fs::path& input : r.inputs) {
    if (input.empty() || !fs::exists(input, ec)) continue;
    const bool holds = Holds(target, input), inside = Holds(input, target);
    if (holds || inside) {
      throw Error(target.string() + ": is " +
                  (holds && inside ? ""
                   : holds         ? "a folder holding "
                                   : "part of ") +
                  "this command's input " + input.string() + "; choose another output");
    }
  }
  if (!r.allowed) {
    throw Error(target.string() + ": already exists; choose another output, or --replace to replace " +
                (r.kind.empty() ? "it" : r.kind + " there"));
  }
  const bool is_kind = !fs::is_symlink(fs::symlink_status(target, ec)) && r.holds_kind && r.holds_kind(target);
  if (!is_kind) {
    throw Error(target.string() + ": --replace replaces only " + r.kind +
                ", and this is not one; move it away or choose another output");
  }
}

std::size_t RemoveStaleTemporariesOf(const fs::path& target_in) {
  const fs::path target = WithoutTrailingSlash(target_in);
  const fs::path parent = ParentOrDot(target);
  const std::string name = target.filename().string();
  const std::string stem = target.stem().string();
  const std::string ext = target.extension().string();
  std::error_code ec;
  std::size_t count = 0;
  for (auto it = fs::directory_iterator(parent, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string entry = it->path().filename().string();
    std::optional<long> pid = TemporaryWriterPid(entry, name, "");
    const std::optional<long> moved_aside_by = TemporaryWriterPid(entry, name + ".old", "");
    if (!pid && !ext.empty()) pid = TemporaryWriterPid(entry, stem, ext);
    if (moved_aside_by && ProcessIsGone(*moved_aside_by)) {
      std::error_code io;
      // A writer killed between moving the old folder aside and moving the
      // new one in: the old one is still the target.
      if (!fs::exists(fs::symlink_status(target, io))) {
        fs::rename(it->path(), target, io);
        if (!io) spdlog::warn("{}: restored from {}, which a killed run had moved aside", target.string(), entry);
      } else {
        fs::remove_all(it->path(), io);
      }
      if (!io) ++count;
    } else if (pid && ProcessIsGone(*pid)) {
      std::error_code io;
      fs::remove_all(it->path(), io);
      if (!io) {
        spdlog::info("removed {}, left by a killed run writing {}", (parent / entry).string(), target.string());
        ++count;
      }
    }
  }
  return count;
}

bool IsAtomicTemporaryName(std::string_view name) {
  // "." then a name, then ".tmp-" digits "-" digits, then an optional extension.
  if (name.size() < 2 || name[0] != '.') return false;
  for (std::size_t at = name.find(".tmp-", 1); at != std::string_view::npos; at = name.find(".tmp-", at + 1)) {
    std::size_t i = at + 5;
    const std::size_t pid_begin = i;
    while (i < name.size() && std::isdigit(static_cast<unsigned char>(name[i]))) ++i;
    if (i == pid_begin || i >= name.size() || name[i] != '-') continue;
    const std::size_t count_begin = ++i;
    while (i < name.size() && std::isdigit(static_cast<unsigned char>(name[i]))) ++i;
    if (i == count_begin) continue;
    if (i == name.size() || (name[i] == '.' && name.find('.', i + 1) == std::string_view::npos)) return at > 1;
  }
  return false;
}

std::size_t RemoveStaleTemporaries(const fs::path& dir) {
  std::vector<fs::path> stale;
  for (auto it = fs::recursive_directory_iterator(dir); it != fs::recursive_directory_iterator(); ++it) {
    if (IsAtomicTemporaryName(it->path().filename().string())) {
      stale.push_back(it->path());
      if (it->is_directory()) it.disable_recursion_pending();
    }
  }
  for (const fs::path& p : stale) fs::remove_all(p);
  return stale.size();
}

void SyncPath(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Error(path.string() + ": cannot open to sync: " + std::strerror(errno));
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) throw Error(path.string() + ": fsync failed: " + std::strerror(err));
}

AtomicFile::AtomicFile(fs::path target) : target_(std::move(target)) {
  // ".name.tmp-PID-N.ext": hidden, same folder (so rename is atomic), same extension.
  temp_ = ParentOrDot(target_) / ("." + target_.stem().string() + TemporarySuffix() + target_.extension().string());
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(temp_, ec);
  }
}

void AtomicFile::Commit() {
  if (!fs::exists(temp_)) throw Error(target_.string() + ": nothing was written to commit");
  SyncPath(temp_);
  std::error_code ec;
  fs::rename(temp_, target_, ec);
  if (ec) throw Error(target_.string() + ": cannot move temporary file into place: " + ec.message());
  committed_ = true;
  SyncPath(ParentOrDot(target_));
}

AtomicDirectory::AtomicDirectory(fs::path target, const OutputReplacement& replacement)
    : target_(WithoutTrailingSlash(std::move(target))), replacement_(replacement) {
  RemoveStaleTemporariesOf(target_);
  ExpectReplaceable(target_, replacement_);
  std::error_code ec;
  existed_ = fs::exists(fs::symlink_status(target_, ec));
  temp_ = ParentOrDot(target_) / ("." + target_.filename().string() + TemporarySuffix());
  fs::create_directories(temp_, ec);
  if (ec) throw Error(temp_.string() + ": cannot create folder: " + ec.message());
}

AtomicDirectory::~AtomicDirectory() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

void AtomicDirectory::Commit() {
  for (const auto& entry : fs::recursive_directory_iterator(temp_)) {
    if (entry.is_regular_file()) SyncPath(entry.path());
  }
  SyncPath(temp_);
  std::error_code ec;
  const bool exists = fs::exists(fs::symlink_status(target_, ec));
  if (exists && !existed_) throw Error(target_.string() + ": appeared while writing; not replaced");
  if (exists) ExpectReplaceable(target_, replacement_);  // it may have changed meanwhile
  if (!exists) {
    fs::rename(temp_, target_, ec);
    if (ec) throw Error(target_.string() + ": cannot move new folder into place: " + ec.message());
    committed_ = true;
    SyncPath(ParentOrDot(target_));
    return;
  }
  // One atomic swap: at no moment is there no package at the target. The
  // temporary name then holds the old folder, removed below (or, if this
  // process dies first, at the next start of a writer of this target).
  if (::renameat2(AT_FDCWD, temp_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE) == 0) {
    committed_ = true;
    SyncPath(ParentOrDot(target_));
    fs::remove_all(temp_, ec);
    return;
  }
  if (errno != EINVAL && errno != ENOSYS) {
    throw Error(target_.string() + ": cannot swap the new folder into place: " + std::strerror(errno));
  }
  // A file system without the swap: move the old folder aside first.
  const fs::path old = ParentOrDot(target_) / ("." + target_.filename().string() + ".old" + TemporarySuffix());
  fs::rename(target_, old, ec);
  if (ec) throw Error(target_.string() + ": cannot move old folder aside: " + ec.message());
  fs::rename(temp_, target_, ec);
  if (ec) {
    fs::rename(old, target_, ec);  // put the old one back
    throw Error(target_.string() + ": cannot move new folder into place: " + ec.message());
  }
  committed_ = true;
  SyncPath(ParentOrDot(target_));
  fs::remove_all(old, ec);
}

std::string FullDiskNote(const fs::path& path) {
  fs::path existing = path;
  std::error_code ec;
  while (!existing.empty() && !fs::exists(existing, ec)) existing = existing.parent_path();
  if (existing.empty()) return "";
  const fs::space_info space = fs::space(existing, ec);
  if (ec || space.available >= (std::uintmax_t{1} << 20)) return "";
  return "; no space left on the device (" + std::to_string(space.available) + " bytes free)";
}

void WriteTextFileAtomically(const fs::path& target, std::string_view contents) {
  AtomicFile file(target);
  {
    std::ofstream out(file.temp_path(), std::ios::binary);
    if (!out) {
      // Named for the target: the temporary's name means nothing to the user.
      const int error = errno;
      ExpectOutputFolder(target);
      throw Error(target.string() + ": cannot create the file in " + ParentOrDot(target).string() + ": " +
                  std::strerror(error));
    }
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.flush();
    out.close();
    if (!out) throw Error(target.string() + ": write failed" + FullDiskNote(target));
  }
  file.Commit();
}

void WriteJsonFileAtomically(const fs::path& target, const nlohmann::json& value) {
  WriteTextFileAtomically(target, value.dump(2) + "\n");
}

}  // namespace mesocap::core
