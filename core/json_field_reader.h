// Validated reading of JSON documents: every accessor checks presence, type
// and range, and a failure throws FormatError naming the file and the full
// field path ("cameras[1].intrinsics.fx") and what was expected.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

namespace mesocap::core {

// Parses a JSON file. Rejects missing files, files over `max_bytes` (checked
// before reading), nesting deeper than `max_depth` (checked while parsing, so
// a hostile "[[[[..." neither exhausts memory nor later overflows the stack of
// a recursive walk), numbers beyond a double, and syntax errors, with the
// byte offset of the error.
nlohmann::json ReadJsonFile(const std::filesystem::path& file, std::uintmax_t max_bytes = 64ull << 20,
                            int max_depth = 64);

// Whether `file` is a JSON document (as ReadJsonFile reads it) that `test`
// accepts; false for anything unreadable. For --replace's check of what an
// existing output holds.
bool JsonFileHolds(const std::filesystem::path& file, const std::function<bool(const nlohmann::json&)>& test,
                   std::uintmax_t max_bytes = 64ull << 20);

// Throws FormatError when `document` nests arrays and objects deeper than
// `max_depth` (the root counts as 1); `where` is the document's field path.
// For documents parsed from text other than a file (journal lines).
void RejectDeepNesting(const nlohmann::json& document, const std::filesystem::path& file, int max_depth,
                       const std::string& where = "");

// A JSON value as text for a message: at most 40 characters, cut as
// core::Cut() does.
std::string JsonExcerpt(const nlohmann::json& value);

// A view of one JSON object inside a file. Cheap to copy; holds a reference
// to the document, which must outlive it.
class JsonFieldReader {
 public:
  // `where` is the path of this object in the document ("" for the root).
  JsonFieldReader(const nlohmann::json& object, std::filesystem::path file, std::string where = "");

  bool Has(std::string_view key) const;

  // Finite numbers inside [min, max].
  double Number(std::string_view key, double min = -1e300, double max = 1e300) const;
  double NumberOr(std::string_view key, double fallback, double min = -1e300, double max = 1e300) const;
  std::int64_t Integer(std::string_view key, std::int64_t min, std::int64_t max) const;
  bool Boolean(std::string_view key) const;
  std::string String(std::string_view key) const;
  std::string StringOr(std::string_view key, std::string fallback) const;
  // One of `allowed`.
  std::string Choice(std::string_view key, const std::vector<std::string>& allowed) const;

  // A list of exactly `count` finite numbers, each inside [min, max].
  std::vector<double> Numbers(std::string_view key, std::size_t count, double min = -1e300, double max = 1e300) const;
  Eigen::Vector3d Vector3(std::string_view key, double min = -1e300, double max = 1e300) const;
  Eigen::Vector2d Vector2(std::string_view key, double min = -1e300, double max = 1e300) const;

  JsonFieldReader Object(std::string_view key) const;
  // A list of objects, at most `max_count` of them.
  std::vector<JsonFieldReader> Objects(std::string_view key, std::size_t max_count) const;
  const nlohmann::json& Raw(std::string_view key) const;
  const nlohmann::json& json() const { return object_; }

  // Rejects members other than `allowed`, so a misspelt or newer field (say a
  // rational-model "k4") is never silently ignored.
  void RejectUnknownMembers(std::initializer_list<std::string_view> allowed) const;

  // Checks the "format" and "version" members every mesocap file carries.
  void ExpectFormat(std::string_view format, int version) const;
  // The same for a reader of every version from `oldest` to `newest`;
  // returns the file's version.
  int ExpectFormat(std::string_view format, int oldest, int newest) const;

  std::string FieldPath(std::string_view key) const;
  [[noreturn]] void Fail(std::string_view key, const std::string& problem) const;
  const std::filesystem::path& file() const { return file_; }

 private:
  const nlohmann::json& Member(std::string_view key) const;

  const nlohmann::json& object_;
  std::filesystem::path file_;
  std::string where_;
};

}  // namespace mesocap::core
