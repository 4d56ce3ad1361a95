// The bearer token file: made with mode 0600 and 32 random bytes as hex,
// reused while valid, refused with a message naming the file and the
// problem when another mode, owner, kind or content; tokens compared whole.
#include "acquisition/bearer_token.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fstream>

#include "tests/common/error_of.h"
#include "tests/common/file_bytes.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;
using testing::ErrorOf;

unsigned ModeOf(const fs::path& file) {
  struct stat st {};
  EXPECT_EQ(::lstat(file.c_str(), &st), 0) << file;
  return st.st_mode & 07777;
}

TEST(BearerTokenTest, IsMadeWithMode0600AndReusedWhileValid) {
  testing::TemporaryDirectory dir;
  const fs::path file = dir / "control.token";
  // Even under a permissive umask, and one that takes the owner's bits.
  for (const mode_t mask : {mode_t{0}, mode_t{0277}}) {
    const mode_t old = ::umask(mask);
    const std::string token = OpenOrCreateBearerTokenFile(file);
    ::umask(old);
    EXPECT_TRUE(IsBearerToken(token)) << token;
    EXPECT_EQ(ModeOf(file), 0600u);
    EXPECT_EQ(testing::Slurp(file), token + "\n");
    EXPECT_EQ(OpenOrCreateBearerTokenFile(file), token);  // reused
    EXPECT_EQ(ReadBearerTokenFile(file), token);
    fs::remove(file);
  }
  // Nothing but the token file is left (no temporary).
  EXPECT_TRUE(fs::is_empty(dir.path()));
  // Fresh tokens differ: 256 random bits each.
  const std::string a = OpenOrCreateBearerTokenFile(file);
  fs::remove(file);
  EXPECT_NE(OpenOrCreateBearerTokenFile(file), a);
}

TEST(BearerTokenTest, AFileOfAnotherModeKindOrContentIsRefusedByName) {
  testing::TemporaryDirectory dir;
  const fs::path file = dir / "control.token";
  const std::string remedy = "; remove it and mesocapd makes a new one";
  const std::string token(64, 'c');
  std::ofstream(file) << token << "\n";
  fs::permissions(file,
                  fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read | fs::perms::others_read);
  EXPECT_EQ(ErrorOf([&] { OpenOrCreateBearerTokenFile(file); }),
            file.string() + ": mode 0644, expected 0600 (only mesocapd's user may read the bearer token)" + remedy);
  EXPECT_EQ(ReadBearerTokenFile(file), token);  // a client reads it whatever its mode
  fs::permissions(file, fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(OpenOrCreateBearerTokenFile(file), token);

  const std::string content_error =
      ": expected a bearer token (64 lowercase hex digits and a newline, as mesocapd writes it)";
  for (const std::string& bad : {std::string(63, 'c'), std::string(65, 'c'), std::string(64, 'C'), std::string(64, 'g'),
                                 token + "\n\n", std::string()}) {
    std::ofstream(file, std::ios::trunc) << bad;
    EXPECT_EQ(ErrorOf([&] { OpenOrCreateBearerTokenFile(file); }), file.string() + content_error + remedy)
        << "content of " << bad.size() << " bytes";
    EXPECT_EQ(ErrorOf([&] { ReadBearerTokenFile(file); }), file.string() + content_error);
  }
  fs::remove(file);
  fs::create_symlink(dir / "elsewhere", file);
  EXPECT_EQ(ErrorOf([&] { OpenOrCreateBearerTokenFile(file); }), file.string() + ": not a regular file" + remedy);
  EXPECT_FALSE(fs::exists(dir / "elsewhere"));  // nothing written through the link
  fs::remove(file);
  fs::create_directory(file);
  EXPECT_EQ(ErrorOf([&] { OpenOrCreateBearerTokenFile(file); }), file.string() + ": not a regular file" + remedy);
  EXPECT_EQ(ErrorOf([&] { ReadBearerTokenFile(dir / "missing"); }),
            (dir / "missing").string() + ": cannot read the bearer token: No such file or directory");
}

TEST(BearerTokenTest, TokensAreEqualOnlyWhole) {
  const std::string token(64, 'e');
  EXPECT_TRUE(BearerTokensEqual(token, token));
  EXPECT_FALSE(BearerTokensEqual(token, token.substr(0, 63)));
  EXPECT_FALSE(BearerTokensEqual(token, token + "e"));
  EXPECT_FALSE(BearerTokensEqual(token, ""));
  EXPECT_TRUE(BearerTokensEqual("", ""));
  for (std::size_t i = 0; i < token.size(); ++i) {
    std::string other = token;
    other[i] = 'f';
    EXPECT_FALSE(BearerTokensEqual(token, other)) << i;
  }
  EXPECT_FALSE(BearerTokensEqual(std::string("a\0b", 3), std::string("a\0c", 3)));
}

}  // namespace
}  // namespace mesocap::acquisition
