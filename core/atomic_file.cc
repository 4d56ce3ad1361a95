#include "core/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <vector>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"

namespace mesocap::core {
namespace fs = std::filesystem;
namespace {

// Unique within the process (counter) and across processes (pid).
std::string TemporarySuffix() {
  static std::atomic<unsigned> counter{0};
  return ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

fs::path ParentOrDot(const fs::path& p) {
  return p.has_parent_path() ? p.parent_path() : fs::path(".");
}

}  // namespace

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
  temp_ = ParentOrDot(target_) /
          ("." + target_.stem().string() + TemporarySuffix() + target_.extension().string());
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

AtomicDirectory::AtomicDirectory(fs::path target, bool replace)
    : target_(std::move(target)), replace_(replace) {
  if (target_.filename().empty()) target_ = target_.parent_path();  // "out/" -> "out"
  if (fs::exists(target_) && !replace_) {
    throw Error(target_.string() + ": already exists; choose another output or allow replacing it");
  }
  temp_ = ParentOrDot(target_) / ("." + target_.filename().string() + TemporarySuffix());
  std::error_code ec;
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
  fs::path old;
  if (fs::exists(target_)) {
    if (!replace_) throw Error(target_.string() + ": appeared while writing; not replaced");
    old = ParentOrDot(target_) / ("." + target_.filename().string() + ".old" + TemporarySuffix());
    fs::rename(target_, old, ec);
    if (ec) throw Error(target_.string() + ": cannot move old folder aside: " + ec.message());
  }
  fs::rename(temp_, target_, ec);
  if (ec) {
    if (!old.empty()) fs::rename(old, target_, ec);  // put the old one back
    throw Error(target_.string() + ": cannot move new folder into place: " + ec.message());
  }
  committed_ = true;
  SyncPath(ParentOrDot(target_));
  if (!old.empty()) fs::remove_all(old, ec);
}

void WriteTextFileAtomically(const fs::path& target, std::string_view contents) {
  AtomicFile file(target);
  {
    std::ofstream out(file.temp_path(), std::ios::binary);
    if (!out) throw Error(file.temp_path().string() + ": cannot create file");
    out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
    out.flush();
    if (!out) throw Error(file.temp_path().string() + ": write failed");
  }
  file.Commit();
}

void WriteJsonFileAtomically(const fs::path& target, const nlohmann::json& value) {
  WriteTextFileAtomically(target, value.dump(2) + "\n");
}

}  // namespace mesocap::core
