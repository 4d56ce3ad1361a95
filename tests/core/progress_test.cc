#include "core/progress.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

namespace mesocap::core {
namespace {

std::vector<std::string> Lines(std::FILE* f) {
  std::rewind(f);
  std::vector<std::string> lines;
  char buf[512];
  while (std::fgets(buf, sizeof buf, f)) lines.emplace_back(buf);
  return lines;
}

TEST(Progress, JsonLinesAreParseableAndEndComplete) {
  std::FILE* f = std::tmpfile();
  ASSERT_NE(f, nullptr);
  {
    Progress p("rectify", 100, Progress::Style::kJsonLines, f);
    for (int i = 0; i < 100; ++i) p.Advance();
  }
  const auto lines = Lines(f);
  std::fclose(f);
  // Throttled: one line per 10 % at most (plus the final one), not one per item.
  ASSERT_GE(lines.size(), 2u);
  EXPECT_LE(lines.size(), 11u);
  for (const auto& l : lines) {
    const auto j = nlohmann::json::parse(l);
    EXPECT_EQ(j["task"], "rectify");
    EXPECT_EQ(j["total"], 100);
  }
  EXPECT_EQ(nlohmann::json::parse(lines.back())["done"], 100);
  EXPECT_NE(lines[lines.size() - 2], lines.back()) << "final state printed twice";
}

TEST(Progress, NeverExceedsTotalAndFinishesOnce) {
  std::FILE* f = std::tmpfile();
  Progress p("x", 3, Progress::Style::kJsonLines, f);
  p.Advance(10);
  EXPECT_EQ(p.done(), 3u);
  p.Finish();
  p.Finish();
  const auto n = Lines(f).size();
  p.Advance();
  EXPECT_EQ(Lines(f).size(), n);
  std::fclose(f);
}

TEST(Progress, AutoIsJsonWhenNotATerminal) {
  std::FILE* f = std::tmpfile();
  Progress p("x", 1, Progress::Style::kAuto, f);
  EXPECT_EQ(p.style(), Progress::Style::kJsonLines);
  p.Finish();
  std::fclose(f);
}

}  // namespace
}  // namespace mesocap::core
