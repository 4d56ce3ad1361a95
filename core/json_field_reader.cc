#include "core/json_field_reader.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.h"

namespace mesocap::core {
namespace fs = std::filesystem;

namespace {

std::string Describe(const nlohmann::json& v) {
  return v.is_null() ? std::string("null") : std::string(v.type_name()) + " " + JsonExcerpt(v);
}

std::string RangeText(double min, double max) {
  std::ostringstream s;
  if (min <= -1e300 && max >= 1e300) return "a finite number";
  s << "a finite number in [" << min << ", " << max << "]";
  return s.str();
}

}  // namespace

std::string JsonExcerpt(const nlohmann::json& value) {
  // Replacing invalid UTF-8 keeps dump() from throwing on a string read from
  // a file that is not UTF-8 throughout.
  return Cut(value.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), 40);
}

bool JsonFileHolds(const fs::path& file, const std::function<bool(const nlohmann::json&)>& test,
                   std::uintmax_t max_bytes) {
  try {
    return test(ReadJsonFile(file, max_bytes));
  } catch (const Error&) {
    return false;
  } catch (const nlohmann::json::exception&) {
    return false;
  }
}

nlohmann::json ReadJsonFile(const fs::path& file, std::uintmax_t max_bytes, int max_depth) {
  std::error_code ec;
  if (!fs::exists(file, ec)) throw FormatError(file, "", "file not found");
  if (!fs::is_regular_file(file, ec)) throw FormatError(file, "", "not a regular file");
  const auto size = fs::file_size(file, ec);
  if (ec) throw FormatError(file, "", "cannot read size: " + ec.message());
  if (size > max_bytes) {
    throw FormatError(file, "",
                      "file is " + std::to_string(size) + " bytes; at most " + std::to_string(max_bytes) + " expected");
  }
  std::ifstream in(file, std::ios::binary);
  if (!in) throw FormatError(file, "", "cannot open for reading");
  std::string text(size, '\0');
  in.read(text.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) throw FormatError(file, "", "short read");
  // Parsed without a callback, then checked for depth: nlohmann's parser and
  // its destructor are iterative, so deep nesting costs no stack, while the
  // callback parser (3.11.2) rescans the parent on every object's end, which
  // is quadratic: a hostile list of 100 k objects took 2 s (100 s under
  // ASan), and a 16 MiB one would take hours.
  nlohmann::json document;
  try {
    document = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw FormatError(file, "", "not valid JSON (at byte " + std::to_string(e.byte) + ")");
  } catch (const nlohmann::json::out_of_range&) {  // 1e400
    throw FormatError(file, "", "not valid JSON: a number beyond the range of a double");
  } catch (const nlohmann::json::exception&) {
    throw FormatError(file, "", "not valid JSON");
  }
  RejectDeepNesting(document, file, max_depth, "");
  return document;
}

void RejectDeepNesting(const nlohmann::json& document, const fs::path& file, int max_depth, const std::string& where) {
  // Iterative on purpose: the point is to survive documents that would
  // overflow the stack of a recursive walk.
  std::vector<std::pair<const nlohmann::json*, int>> pending = {{&document, 1}};
  while (!pending.empty()) {
    const auto [value, depth] = pending.back();
    pending.pop_back();
    if (!value->is_structured()) continue;
    if (depth > max_depth) {
      throw FormatError(file, where, "arrays and objects nest deeper than " + std::to_string(max_depth) + " levels");
    }
    for (const auto& child : *value) {
      if (child.is_structured()) pending.emplace_back(&child, depth + 1);
    }
  }
}

JsonFieldReader::JsonFieldReader(const nlohmann::json& object, fs::path file, std::string where)
    : object_(object), file_(std::move(file)), where_(std::move(where)) {
  if (!object_.is_object()) throw FormatError(file_, where_, "expected an object, got " + Describe(object_));
}

std::string JsonFieldReader::FieldPath(std::string_view key) const {
  if (where_.empty()) return std::string(key);
  if (key.empty()) return where_;
  if (key.front() == '[') return where_ + std::string(key);
  return where_ + "." + std::string(key);
}

void JsonFieldReader::Fail(std::string_view key, const std::string& problem) const {
  throw FormatError(file_, FieldPath(key), problem);
}

bool JsonFieldReader::Has(std::string_view key) const { return object_.contains(key); }

const nlohmann::json& JsonFieldReader::Member(std::string_view key) const {
  auto it = object_.find(key);
  if (it == object_.end()) Fail(key, "missing");
  return *it;
}

const nlohmann::json& JsonFieldReader::Raw(std::string_view key) const { return Member(key); }

double JsonFieldReader::Number(std::string_view key, double min, double max) const {
  const auto& v = Member(key);
  if (!v.is_number()) Fail(key, "expected " + RangeText(min, max) + ", got " + Describe(v));
  const double x = v.get<double>();
  if (!std::isfinite(x) || x < min || x > max) {
    Fail(key, "expected " + RangeText(min, max) + ", got " + Describe(v));
  }
  return x;
}

double JsonFieldReader::NumberOr(std::string_view key, double fallback, double min, double max) const {
  return Has(key) ? Number(key, min, max) : fallback;
}

std::int64_t JsonFieldReader::Integer(std::string_view key, std::int64_t min, std::int64_t max) const {
  const auto& v = Member(key);
  const std::string expected = "an integer in [" + std::to_string(min) + ", " + std::to_string(max) + "]";
  if (!v.is_number_integer()) Fail(key, "expected " + expected + ", got " + Describe(v));
  // Unsigned values beyond int64 are out of range too.
  if (v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(max)) {
    Fail(key, "expected " + expected + ", got " + Describe(v));
  }
  const auto x = v.get<std::int64_t>();
  if (x < min || x > max) Fail(key, "expected " + expected + ", got " + Describe(v));
  return x;
}

bool JsonFieldReader::Boolean(std::string_view key) const {
  const auto& v = Member(key);
  if (!v.is_boolean()) Fail(key, "expected true or false, got " + Describe(v));
  return v.get<bool>();
}

std::string JsonFieldReader::String(std::string_view key) const {
  const auto& v = Member(key);
  if (!v.is_string()) Fail(key, "expected a string, got " + Describe(v));
  return v.get<std::string>();
}

std::string JsonFieldReader::StringOr(std::string_view key, std::string fallback) const {
  return Has(key) ? String(key) : fallback;
}

std::string JsonFieldReader::Choice(std::string_view key, const std::vector<std::string>& allowed) const {
  const std::string s = String(key);
  for (const auto& a : allowed) {
    if (s == a) return s;
  }
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + ("\"" + a + "\"");
  Fail(key, "expected one of " + list + ", got " + Quoted(s));
}

std::vector<double> JsonFieldReader::Numbers(std::string_view key, std::size_t count, double min, double max) const {
  const auto& v = Member(key);
  if (!v.is_array() || v.size() != count) {
    Fail(key, "expected a list of " + std::to_string(count) + " numbers, got " + Describe(v));
  }
  std::vector<double> out;
  out.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const auto& e = v[i];
    if (!e.is_number() || !std::isfinite(e.get<double>()) || e.get<double>() < min || e.get<double>() > max) {
      Fail(std::string(key) + "[" + std::to_string(i) + "]",
           "expected " + RangeText(min, max) + ", got " + Describe(e));
    }
    out.push_back(e.get<double>());
  }
  return out;
}

Eigen::Vector3d JsonFieldReader::Vector3(std::string_view key, double min, double max) const {
  const auto n = Numbers(key, 3, min, max);
  return {n[0], n[1], n[2]};
}

Eigen::Vector2d JsonFieldReader::Vector2(std::string_view key, double min, double max) const {
  const auto n = Numbers(key, 2, min, max);
  return {n[0], n[1]};
}

JsonFieldReader JsonFieldReader::Object(std::string_view key) const {
  const auto& v = Member(key);
  if (!v.is_object()) Fail(key, "expected an object, got " + Describe(v));
  return JsonFieldReader(v, file_, FieldPath(key));
}

std::vector<JsonFieldReader> JsonFieldReader::Objects(std::string_view key, std::size_t max_count) const {
  const auto& v = Member(key);
  if (!v.is_array()) Fail(key, "expected a list, got " + Describe(v));
  if (v.size() > max_count) {
    Fail(key, "expected at most " + std::to_string(max_count) + " entries, got " + std::to_string(v.size()));
  }
  std::vector<JsonFieldReader> out;
  out.reserve(v.size());
  for (std::size_t i = 0; i < v.size(); ++i) {
    const std::string at = FieldPath(key) + "[" + std::to_string(i) + "]";
    if (!v[i].is_object()) throw FormatError(file_, at, "expected an object, got " + Describe(v[i]));
    out.emplace_back(v[i], file_, at);
  }
  return out;
}

void JsonFieldReader::RejectUnknownMembers(std::initializer_list<std::string_view> allowed) const {
  for (const auto& [key, value] : object_.items()) {
    bool known = false;
    for (const auto a : allowed) known = known || key == a;
    if (!known) {
      std::string list;
      for (const auto a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      // The key cut short: with the list of members the line stays readable.
      Fail(Cut(key, 60), "unknown member; expected only " + list);
    }
  }
}

void JsonFieldReader::ExpectFormat(std::string_view format, int version) const {
  ExpectFormat(format, version, version);
}

int JsonFieldReader::ExpectFormat(std::string_view format, int oldest, int newest) const {
  const std::string f = String("format");
  if (f != format) Fail("format", "expected \"" + std::string(format) + "\", got " + Quoted(f));
  const auto v = Integer("version", 0, 1 << 30);
  if (v < oldest || v > newest) {
    const std::string readable = oldest == newest
                                     ? "version " + std::to_string(newest)
                                     : "versions " + std::to_string(oldest) + " to " + std::to_string(newest);
    Fail("version", "this build reads " + readable + ", the file is version " + std::to_string(v));
  }
  return static_cast<int>(v);
}

}  // namespace mesocap::core
