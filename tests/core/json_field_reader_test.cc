#include "core/json_field_reader.h"

#include <gtest/gtest.h>

#include <fstream>

#include "core/error.h"
#include "tests/common/error_of.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::core {
namespace {

using nlohmann::json;

// The message of the FormatError `f` throws.
template <typename F>
std::string ErrorOf(F&& f) {
  return testing::ErrorOf<FormatError>(std::forward<F>(f));
}

TEST(JsonFieldReader, NamesFileAndFieldPath) {
  const json doc = json::parse(R"({"cameras": [{"fx": 1000}, {"fx": "wide"}]})");
  JsonFieldReader root(doc, "calib.json");
  const auto cams = root.Objects("cameras", 8);
  EXPECT_EQ(cams[0].Number("fx", 1, 1e6), 1000);
  const std::string msg = ErrorOf([&] { cams[1].Number("fx"); });
  EXPECT_NE(msg.find("calib.json"), std::string::npos) << msg;
  EXPECT_NE(msg.find("cameras[1].fx"), std::string::npos) << msg;
  EXPECT_NE(msg.find("finite number"), std::string::npos) << msg;
}

TEST(JsonFieldReader, RangesMissingAndTypes) {
  const json doc = json::parse(R"({"n": -3, "big": 18446744073709551615, "s": "x", "v": [1, 2]})");
  JsonFieldReader r(doc, "f.json");
  EXPECT_NE(ErrorOf([&] { r.Integer("n", 0, 10); }).find("[0, 10]"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { r.Integer("big", 0, 1000); }).find("big"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { r.Number("missing"); }).find("missing"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { r.Vector3("v"); }).find("3 numbers"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { r.Choice("s", {"a", "b"}); }).find("\"a\", \"b\""), std::string::npos);
  EXPECT_EQ(r.NumberOr("absent", 2.5), 2.5);
}

TEST(JsonFieldReader, FormatAndVersion) {
  const json doc = json::parse(R"({"format": "mesocap.calibration", "version": 2})");
  JsonFieldReader r(doc, "c.json");
  EXPECT_NE(ErrorOf([&] { r.ExpectFormat("mesocap.calibration", 1); }).find("version 2"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { r.ExpectFormat("mesocap.material", 1); }).find("format"), std::string::npos);
  // A reader of a range of versions returns the file's and names the range.
  EXPECT_EQ(r.ExpectFormat("mesocap.calibration", 1, 2), 2);
  EXPECT_EQ(r.ExpectFormat("mesocap.calibration", 2, 3), 2);
  EXPECT_NE(
      ErrorOf([&] { r.ExpectFormat("mesocap.calibration", 3, 4); }).find("versions 3 to 4, the file is version 2"),
      std::string::npos);
}

TEST(ReadJsonFile, RejectsMissingOversizeAndMalformed) {
  testing::TemporaryDirectory dir;
  EXPECT_NE(ErrorOf([&] { ReadJsonFile(dir / "none.json"); }).find("not found"), std::string::npos);
  std::ofstream(dir / "bad.json") << "{\"a\": [1, 2";
  EXPECT_NE(ErrorOf([&] { ReadJsonFile(dir / "bad.json"); }).find("not valid JSON"), std::string::npos);
  std::ofstream(dir / "big.json") << std::string(2000, ' ') << "{}";
  EXPECT_NE(ErrorOf([&] { ReadJsonFile(dir / "big.json", 1000); }).find("at most 1000"), std::string::npos);
}

TEST(ReadJsonFile, RejectsDeepNestingWhileParsingAndHugeNumbers) {
  testing::TemporaryDirectory dir;
  std::ofstream(dir / "deep.json") << std::string(100000, '[') << std::string(100000, ']');
  EXPECT_NE(ErrorOf([&] { ReadJsonFile(dir / "deep.json"); }).find("nest deeper than 64"), std::string::npos);
  std::ofstream(dir / "ok.json") << std::string(64, '[') << std::string(64, ']');
  EXPECT_NO_THROW(ReadJsonFile(dir / "ok.json"));
  std::ofstream(dir / "too.json") << std::string(65, '[') << std::string(65, ']');
  EXPECT_THROW(ReadJsonFile(dir / "too.json"), FormatError);
  std::ofstream(dir / "huge.json") << R"({"fx": 1e400})";
  EXPECT_NE(ErrorOf([&] { ReadJsonFile(dir / "huge.json"); }).find("huge.json"), std::string::npos);
}

TEST(JsonFieldReader, UnknownMembersAreNamed) {
  const json doc = json::parse(R"({"k1": 0, "k4": 0.1})");
  JsonFieldReader r(doc, "d.json", "distortion");
  EXPECT_NE(ErrorOf([&] { r.RejectUnknownMembers({"k1", "k2"}); }).find("distortion.k4"), std::string::npos);
  EXPECT_NO_THROW(r.RejectUnknownMembers({"k1", "k4"}));
}

}  // namespace
}  // namespace mesocap::core
