// The bearer token that guards the capture daemon's loopback TCP listener:
// 32 random bytes (getrandom) as 64 lowercase hex digits, kept in a file
// only the daemon's user may read (mode 0600 from its creation). The Unix
// socket needs none: its own mode is the guard there.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace mesocap::acquisition {

inline constexpr std::size_t kBearerTokenHexDigits = 64;

// Whether `token` has the form a token file holds (64 lowercase hex digits).
bool IsBearerToken(std::string_view token);

// The daemon's side: reuses the token in `file` when it is a regular file of
// this user, mode 0600, holding a token; creates it (mode 0600 from the
// start, written under a temporary name and renamed) when there is none.
// Throws Error naming the file and what is wrong with it otherwise.
std::string OpenOrCreateBearerTokenFile(const std::filesystem::path& file);

// Replaces the token in `file` with a new one (mode 0600, written under a
// temporary name and renamed over the old file) and returns it: clients of
// the old token are refused from then on.
std::string RotateBearerTokenFile(const std::filesystem::path& file);

// Writes `text` to `file` readable by this user only (mode 0600 from its
// creation, renamed into place): the token file, and the status page's
// address that carries the token.
void WriteSecretFile(const std::filesystem::path& file, const std::string& text);

// A client's side: the token in `file` (a trailing newline allowed); Error
// naming the file when it cannot be read or holds no token.
std::string ReadBearerTokenFile(const std::filesystem::path& file);

// Equality whose time depends only on the lengths, not on where the first
// difference is: a client cannot guess a token byte by byte from timings.
bool BearerTokensEqual(std::string_view a, std::string_view b);

}  // namespace mesocap::acquisition
