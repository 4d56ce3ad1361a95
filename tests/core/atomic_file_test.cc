#include "core/atomic_file.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <functional>

#include <fstream>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/json_field_reader.h"
#include "tests/common/killed_writer.h"
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

// A folder "holds the kind" when it has a file named "kind".
OutputReplacement ReplaceKind(bool allowed, std::vector<std::filesystem::path> inputs = {}) {
  return {allowed, "a test folder", [](const std::filesystem::path& p) { return std::filesystem::exists(p / "kind"); },
          std::move(inputs)};
}

std::string MessageOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(AtomicDirectory, RefusesToReplaceUnlessAsked) {
  testing::TemporaryDirectory dir;
  std::filesystem::create_directories(dir / "pkg");
  std::ofstream(dir / "pkg" / "kind") << "precious";
  EXPECT_THAT(MessageOf([&] { AtomicDirectory(dir / "pkg", ReplaceKind(false)); }),
              ::testing::HasSubstr("already exists"));
  {
    AtomicDirectory d(dir / "pkg", ReplaceKind(true));
    std::ofstream(d.temp_path() / "new") << "x";
    // Not committed: the old folder must be intact and no temp folder left.
  }
  EXPECT_EQ(Slurp(dir / "pkg" / "kind"), "precious");
  EXPECT_EQ(CountEntries(dir.path()), 1);
  {
    AtomicDirectory d(dir / "pkg", ReplaceKind(true));
    std::ofstream(d.temp_path() / "new") << "x";
    d.Commit();
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "pkg" / "new"));
  EXPECT_FALSE(std::filesystem::exists(dir / "pkg" / "kind"));
  EXPECT_EQ(CountEntries(dir.path()), 1);
}

// --replace never removes what the command does not write, nor its input.
TEST(AtomicDirectory, ReplacesOnlyItsOwnKindAndNeverAnInput) {
  testing::TemporaryDirectory dir;
  std::filesystem::create_directories(dir / "notes");
  std::ofstream(dir / "notes" / "notes.txt") << "precious";
  EXPECT_THAT(MessageOf([&] { AtomicDirectory(dir / "notes", ReplaceKind(true)); }),
              ::testing::HasSubstr("replaces only a test folder, and this is not one"));
  EXPECT_EQ(Slurp(dir / "notes" / "notes.txt"), "precious");

  std::filesystem::create_directories(dir / "pkg" / "inner");
  std::ofstream(dir / "pkg" / "kind") << "old";
  std::ofstream(dir / "pkg" / "inner" / "input.json") << "{}";
  EXPECT_THAT(MessageOf([&] { AtomicDirectory(dir / "pkg", ReplaceKind(true, {dir / "pkg"})); }),
              ::testing::HasSubstr("is this command's input"));
  EXPECT_THAT(
      MessageOf([&] { AtomicDirectory(dir / "pkg/", ReplaceKind(true, {dir / "pkg" / "inner" / "input.json"})); }),
      ::testing::HasSubstr("holding this command's input"));
  // The same folder by another spelling is still the input.
  EXPECT_THAT(MessageOf([&] { AtomicDirectory(dir / "pkg", ReplaceKind(true, {dir / "notes" / ".." / "pkg"})); }),
              ::testing::HasSubstr("input"));
  EXPECT_EQ(Slurp(dir / "pkg" / "kind"), "old");
  EXPECT_EQ(CountEntries(dir.path()), 2);
}

// A killed writer's folders: its temporary is removed, a folder it had moved
// aside is put back, and a live writer's temporary is left alone.
TEST(AtomicDirectory, StaleTemporariesOfItsTargetAreCleanedAtStart) {
  testing::TemporaryDirectory dir;
  const long dead = testing::DeadPid();
  const std::string d = std::to_string(dead);
  std::filesystem::create_directories(dir / (".pkg.tmp-" + d + "-0") / "btf");
  std::ofstream(dir / (".pkg.tmp-" + d + "-0") / "btf" / "view_0000.exr") << "half";
  std::filesystem::create_directories(dir / (".pkg.old.tmp-" + d + "-1"));
  std::ofstream(dir / (".pkg.old.tmp-" + d + "-1") / "kind") << "the old package";
  const std::string live = ".pkg.tmp-" + std::to_string(::getpid()) + "-99";
  std::filesystem::create_directories(dir / live);
  std::filesystem::create_directories(dir / (".other.tmp-" + d + "-0"));  // another target's

  EXPECT_EQ(RemoveStaleTemporariesOf(dir / "pkg"), 2u);
  EXPECT_EQ(Slurp(dir / "pkg" / "kind"), "the old package");
  EXPECT_TRUE(std::filesystem::exists(dir / live));
  EXPECT_TRUE(std::filesystem::exists(dir / (".other.tmp-" + d + "-0")));
  EXPECT_EQ(CountEntries(dir.path()), 3);
}

TEST(AtomicFile, StaleTemporariesOfItsTargetAreRecognized) {
  testing::TemporaryDirectory dir;
  const std::string d = std::to_string(testing::DeadPid());
  std::ofstream(dir / (".frame.tmp-" + d + "-3.png")) << "half a png";
  std::ofstream(dir / (".frame.tmp-" + d + "-3.exr")) << "another target";
  std::ofstream(dir / "frame.png") << "the old frame";
  EXPECT_EQ(RemoveStaleTemporariesOf(dir / "frame.png"), 1u);
  EXPECT_EQ(CountEntries(dir.path()), 2);
  EXPECT_EQ(Slurp(dir / "frame.png"), "the old frame");
}

}  // namespace
}  // namespace mesocap::core
