#include "acquisition/bearer_token.h"

#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "core/atomic_file.h"
#include "core/error.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;

std::string NewToken() {
  unsigned char bytes[kBearerTokenHexDigits / 2];
  std::size_t filled = 0;
  while (filled < sizeof bytes) {
    const ssize_t n = ::getrandom(bytes + filled, sizeof bytes - filled, 0);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw core::Error(std::string("getrandom: ") + std::strerror(errno));
    filled += static_cast<std::size_t>(n);
  }
  static constexpr char kHex[] = "0123456789abcdef";
  std::string token;
  for (const unsigned char b : bytes) {
    token += kHex[b >> 4];
    token += kHex[b & 15];
  }
  return token;
}

void WriteAll(int fd, std::string_view bytes, const fs::path& file) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw core::Error(file.string() + ": cannot write: " + std::strerror(errno));
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
}

}  // namespace

void WriteSecretFile(const fs::path& file, const std::string& text) {
  core::AtomicFile atomic(file);
  const int fd = ::open(atomic.temp_path().c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw core::Error(atomic.temp_path().string() + ": cannot create: " + std::strerror(errno));
  try {
    // Exactly 0600 whatever the umask took away (it can only take, never add).
    if (::fchmod(fd, 0600) != 0) throw core::Error(file.string() + ": cannot chmod: " + std::strerror(errno));
    WriteAll(fd, text, file);
  } catch (...) {
    ::close(fd);
    throw;
  }
  ::close(fd);
  atomic.Commit();
}

namespace {

std::string Octal(unsigned mode) {
  char text[8];
  std::snprintf(text, sizeof text, "%04o", mode);
  return text;
}

}  // namespace

bool IsBearerToken(std::string_view token) {
  if (token.size() != kBearerTokenHexDigits) return false;
  for (const char c : token) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

std::string ReadBearerTokenFile(const fs::path& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw core::Error(file.string() + ": cannot read the bearer token: " + std::strerror(errno));
  // One byte more than a token and its newline tells a longer file apart.
  char buffer[kBearerTokenHexDigits + 2];
  std::size_t size = 0;
  while (size < sizeof buffer) {
    const ssize_t n = ::read(fd, buffer + size, sizeof buffer - size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    size += static_cast<std::size_t>(n);
  }
  ::close(fd);
  std::string_view token(buffer, size);
  if (!token.empty() && token.back() == '\n') token.remove_suffix(1);
  // The content is a secret, or meant to be one: never echoed.
  if (!IsBearerToken(token)) {
    throw core::Error(file.string() + ": expected a bearer token (" + std::to_string(kBearerTokenHexDigits) +
                      " lowercase hex digits and a newline, as mesocapd writes it)");
  }
  return std::string(token);
}

std::string OpenOrCreateBearerTokenFile(const fs::path& file) {
  struct stat st {};
  if (::lstat(file.c_str(), &st) != 0) {
    if (errno != ENOENT) throw core::Error(file.string() + ": " + std::strerror(errno));
    return RotateBearerTokenFile(file);
  }
  const std::string remedy = "; remove it and mesocapd makes a new one";
  if (!S_ISREG(st.st_mode)) throw core::Error(file.string() + ": not a regular file" + remedy);
  if (st.st_uid != ::geteuid()) {
    throw core::Error(file.string() + ": owned by uid " + std::to_string(st.st_uid) + ", not by mesocapd's (uid " +
                      std::to_string(::geteuid()) + ")" + remedy);
  }
  const unsigned mode = st.st_mode & 07777;
  if (mode != 0600) {
    throw core::Error(file.string() + ": mode " + Octal(mode) +
                      ", expected 0600 (only mesocapd's user may read the bearer token)" + remedy);
  }
  try {
    return ReadBearerTokenFile(file);
  } catch (const core::Error& e) {
    throw core::Error(e.what() + remedy);
  }
}

std::string RotateBearerTokenFile(const fs::path& file) {
  const std::string token = NewToken();
  WriteSecretFile(file, token + "\n");
  return token;
}

bool BearerTokensEqual(std::string_view a, std::string_view b) {
  unsigned char difference = a.size() == b.size() ? 0 : 1;
  const std::size_t n = std::max(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    difference |= static_cast<unsigned char>(x ^ y);
  }
  return difference == 0;
}

}  // namespace mesocap::acquisition
