#include "core/atomic_file.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/json_field_reader.h"
#include "tests/common/temporary_directory.h"

namespace mesocap {
namespace {

std::string Slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), {}};
}

int CountEntries(const std::filesystem::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++n;
  return n;
}

TEST(AtomicFile, UncommittedWriteLeavesOldContents) {
  testing::TemporaryDirectory dir;
  WriteTextFileAtomically(dir / "f.txt", "old");
  {
    AtomicFile f(dir / "f.txt");
    std::ofstream(f.temp_path()) << "new but abandoned";
  }
  EXPECT_EQ(Slurp(dir / "f.txt"), "old");
  EXPECT_EQ(CountEntries(dir.path()), 1);
}

TEST(AtomicFile, CommitReplaces) {
  testing::TemporaryDirectory dir;
  WriteTextFileAtomically(dir / "f.txt", "old");
  WriteJsonFileAtomically(dir / "f.txt", nlohmann::json{{"a", 1}});
  EXPECT_EQ(ReadJsonFile(dir / "f.txt")["a"], 1);
  EXPECT_EQ(CountEntries(dir.path()), 1);
}

TEST(AtomicDirectory, RefusesToReplaceUnlessAsked) {
  testing::TemporaryDirectory dir;
  std::filesystem::create_directories(dir / "pkg");
  std::ofstream(dir / "pkg" / "keep") << "precious";
  EXPECT_THROW(AtomicDirectory(dir / "pkg", false), Error);
  {
    AtomicDirectory d(dir / "pkg", true);
    std::ofstream(d.temp_path() / "new") << "x";
    // Not committed: the old folder must be intact and no temp folder left.
  }
  EXPECT_EQ(Slurp(dir / "pkg" / "keep"), "precious");
  EXPECT_EQ(CountEntries(dir.path()), 1);
  {
    AtomicDirectory d(dir / "pkg", true);
    std::ofstream(d.temp_path() / "new") << "x";
    d.Commit();
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "pkg" / "new"));
  EXPECT_FALSE(std::filesystem::exists(dir / "pkg" / "keep"));
  EXPECT_EQ(CountEntries(dir.path()), 1);
}

}  // namespace
}  // namespace mesocap
