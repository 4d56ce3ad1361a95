// A folder's files as a run writes them, with what differs from run to run
// taken out (creation and step times, the compression's seconds): two runs
// of the same job compare equal byte for byte.
#pragma once

#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "tests/common/file_bytes.h"

namespace mesocap::testing {

// JSON without what differs from run to run: creation and step times, the
// compression's seconds, and the checksum of the file that holds them.
inline nlohmann::json WithoutTimes(nlohmann::json j) {
  if (j.is_object()) {
    for (const char* key : {"created_utc", "time_utc", "seconds"}) j.erase(key);
    if (j.contains("files") && j["files"].is_object()) j["files"].erase("error_report.json");
    for (auto& [key, value] : j.items()) value = WithoutTimes(value);
  } else if (j.is_array()) {
    for (auto& value : j) value = WithoutTimes(value);
  }
  return j;
}

// Every file under `dir`: data files by their bytes, JSON and JSON lines
// without times.
inline std::map<std::string, std::string> Normalized(const std::filesystem::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string name = std::filesystem::relative(e.path(), dir).generic_string();
    std::string bytes = Slurp(e.path());
    const std::string ext = e.path().extension().string();
    if (ext == ".json" || ext == ".jsonl") {
      std::istringstream lines(bytes);
      bytes.clear();
      for (std::string line; std::getline(lines, line, ext == ".jsonl" ? '\n' : '\0');) {
        bytes += WithoutTimes(nlohmann::json::parse(line)).dump() + "\n";
      }
    }
    files[name] = bytes;
  }
  return files;
}

// The files that differ between two Normalized() trees, by name; empty when equal.
inline std::string Differences(const std::map<std::string, std::string>& a,
                               const std::map<std::string, std::string>& b) {
  std::string names;
  for (const auto& [name, bytes] : a) {
    const auto it = b.find(name);
    if (it == b.end() || it->second != bytes) names += " " + name;
  }
  for (const auto& [name, bytes] : b) {
    if (!a.count(name)) names += " " + name + " (only in the second)";
  }
  return names;
}

}  // namespace mesocap::testing
