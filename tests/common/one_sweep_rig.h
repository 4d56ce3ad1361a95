// Shipped rigs cut to one position: the tiny rig cut to one turntable angle,
// one light-arc angle and one laser location of 8 frames is a whole `mesocap
// simulate` session in about a second.
#pragma once

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/json_field_reader.h"

namespace mesocap::testing {

// A shipped rig ("tiny", "small", "paper") cut to one turntable angle, one
// light-arc angle and one laser location; its cameras, lamps and sweep
// length are the shipped ones.
inline nlohmann::json OnePositionRig(const std::string& shipped_rig) {
  nlohmann::json rig =
      core::ReadJsonFile(std::filesystem::path(MESOCAP_SOURCE_DIR) / "sim" / "rigs" / (shipped_rig + ".json"));
  rig["turntable"]["angles_deg"] = {0.0};
  rig["light_arc"]["angles_deg"] = {0.0};
  rig["laser"]["locations"] = nlohmann::json::array({rig["laser"]["locations"][0]});
  return rig;
}

inline nlohmann::json OneSweepRig() {
  nlohmann::json rig = OnePositionRig("tiny");
  rig["laser"]["frames_per_sweep"] = 8;
  return rig;
}

// Writes `rig` to `file` and returns the file's path as text.
inline std::string WriteRig(const std::filesystem::path& file, const nlohmann::json& rig = OneSweepRig()) {
  std::ofstream(file) << rig.dump();
  return file.string();
}

}  // namespace mesocap::testing
