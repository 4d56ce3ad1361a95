#include "core/atomic_file.h"

#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/json_field_reader.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::core {
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

// What a killed writer leaves: the temporaries of both kinds, the names
// AtomicFile really makes, and nothing that merely looks alike.
TEST(AtomicFile, StaleTemporariesAreRecognizedAndRemoved) {
  testing::TemporaryDirectory dir;
  std::string real_name;
  {
    AtomicFile f(dir / "laser" / "t0_loc1_cam0.tif");
    real_name = f.temp_path().filename().string();
  }
  EXPECT_TRUE(IsAtomicTemporaryName(real_name)) << real_name;
  for (const char* name : {".a.tmp-12-0.png", ".manifest.json.tmp-7-3", ".pkg.old.tmp-1-2"}) {
    EXPECT_TRUE(IsAtomicTemporaryName(name)) << name;
  }
  for (const char* name : {"a.tmp-12-0.png", ".tmp-12-0", ".a.tmp-x-0.png", ".a.tmp-12-.png", ".a.tmp-12-0.b.c",
                           ".a.png", "t0_loc1_cam0.tif"}) {
    EXPECT_FALSE(IsAtomicTemporaryName(name)) << name;
  }
  std::filesystem::create_directories(dir / "laser" / ".pkg.tmp-9-9" / "inner");
  std::ofstream(dir / "laser" / ".t0_loc1_cam0.tmp-99-4.tif") << "half a sequence";
  std::ofstream(dir / "laser" / "t0_loc0_cam0.tif") << "a finished file";
  std::ofstream(dir / ".manifest.json.tmp-5-0") << "{";
  EXPECT_EQ(RemoveStaleTemporaries(dir.path()), 3u);
  EXPECT_EQ(CountEntries(dir / "laser"), 1);
  EXPECT_TRUE(std::filesystem::exists(dir / "laser" / "t0_loc0_cam0.tif"));
  EXPECT_EQ(RemoveStaleTemporaries(dir.path()), 0u);
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
}  // namespace mesocap::core
