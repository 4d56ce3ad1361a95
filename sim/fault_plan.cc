#include "sim/fault_plan.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/json_field_reader.h"

namespace mesocap::sim {
namespace {

constexpr std::size_t kMaxRulesPerKind = 4096;
constexpr std::size_t kMaxCounts = 1 << 20;
// Counts stay exact in a JSON double.
constexpr double kMaxCount = 9007199254740992.0;  // 2^53

bool IsStageKind(FaultKind kind) { return kind == FaultKind::kStageStall || kind == FaultKind::kStageTimeout; }
bool IsCameraKind(FaultKind kind) {
  return kind == FaultKind::kCameraDropFrame || kind == FaultKind::kCameraTimeout ||
         kind == FaultKind::kCameraDisconnect;
}

bool IsLampIndex(const std::string& device) {
  return !device.empty() && device.size() <= 9 &&
         std::all_of(device.begin(), device.end(), [](char c) { return c >= '0' && c <= '9'; });
}

FaultRule ParseRule(const core::JsonFieldReader& f, FaultKind kind) {
  f.RejectUnknownMembers({"rate", "at", "device"});
  FaultRule rule;
  rule.kind = kind;
  if (f.Has("rate") == f.Has("at")) f.Fail("", "expected either \"rate\" or \"at\" (exactly one)");
  if (f.Has("rate")) rule.rate = f.Number("rate", 0.0, 1.0);
  if (f.Has("at")) {
    const auto& raw = f.Raw("at");
    if (!raw.is_array() || raw.empty() || raw.size() > kMaxCounts) {
      f.Fail("at", "expected a list of 1 to " + std::to_string(kMaxCounts) + " operation counts");
    }
    const auto counts = f.Numbers("at", raw.size());
    for (std::size_t i = 0; i < counts.size(); ++i) {
      if (counts[i] < 1 || counts[i] > kMaxCount || counts[i] != std::floor(counts[i])) {
        f.Fail("at[" + std::to_string(i) + "]",
               "expected a whole operation count in [1, 2^53] (the first operation is 1), got " +
                   core::JsonExcerpt(f.Raw("at")[i]));
      }
      rule.at.push_back(static_cast<std::uint64_t>(counts[i]));
    }
    // A count listed twice is a slip (the fault happens once either way).
    std::vector<std::uint64_t> sorted = rule.at;
    std::sort(sorted.begin(), sorted.end());
    if (const auto twice = std::adjacent_find(sorted.begin(), sorted.end()); twice != sorted.end()) {
      f.Fail("at", "operation count " + std::to_string(*twice) + " is listed more than once");
    }
  }
  if (f.Has("device")) {
    if (kind == FaultKind::kLampFailure) {
      rule.device = LampDeviceId(static_cast<int>(f.Integer("device", 0, 1 << 20)));
    } else if (IsStageKind(kind)) {
      rule.device = f.Choice("device", {std::string(kTurntableId), std::string(kLightArcId)});
    } else {
      rule.device = f.String("device");
      if (rule.device.empty()) f.Fail("device", "expected a camera id");
    }
  }
  return rule;
}

FaultPlan Parse(const core::JsonFieldReader& root, bool is_file) {
  std::vector<std::string_view> names;
  for (FaultKind k : kAllFaultKinds) names.push_back(ToString(k));
  if (is_file) {
    root.ExpectFormat("mesocap.faults", 1);
    root.RejectUnknownMembers({"format", "version", names[0], names[1], names[2], names[3], names[4], names[5]});
  } else {
    root.RejectUnknownMembers({names[0], names[1], names[2], names[3], names[4], names[5]});
  }
  FaultPlan plan;
  for (FaultKind kind : kAllFaultKinds) {
    const std::string_view key = ToString(kind);
    if (!root.Has(key)) continue;
    if (root.Raw(key).is_array()) {
      for (const auto& rule : root.Objects(key, kMaxRulesPerKind)) plan.rules.push_back(ParseRule(rule, kind));
    } else {
      plan.rules.push_back(ParseRule(root.Object(key), kind));
    }
  }
  return plan;
}

// FNV-1a, then SplitMix64's finalizer to spread the bits.
std::uint64_t Fnv1a(std::uint64_t hash, std::string_view text) {
  for (unsigned char c : text) {
    hash ^= c;
    hash *= 0x100000001b3ull;
  }
  return hash;
}

std::uint64_t Mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

std::string RuleName(std::size_t i, const FaultRule& rule) {
  return "fault rule " + std::to_string(i) + " (" + std::string(ToString(rule.kind)) +
         (rule.device.empty() ? "" : ", device " + core::Quoted(rule.device)) + ")";
}

}  // namespace

std::string LampDeviceId(int lamp) { return std::to_string(lamp); }

core::CheckResult FaultPlan::Check() const {
  for (std::size_t i = 0; i < rules.size(); ++i) {
    const FaultRule& r = rules[i];
    if (r.rate.has_value() == !r.at.empty()) return RuleName(i, r) + ": expected either a rate or operation counts";
    if (r.rate && !(*r.rate >= 0.0 && *r.rate <= 1.0)) {
      return RuleName(i, r) + ": rate " + std::to_string(*r.rate) + " is outside [0, 1]";
    }
    for (std::uint64_t n : r.at) {
      if (n == 0) return RuleName(i, r) + ": operation counts start at 1";
    }
    if (r.kind == FaultKind::kLampFailure && !r.device.empty() && !IsLampIndex(r.device)) {
      return RuleName(i, r) + ": a lamp is named by its index";
    }
    if (IsStageKind(r.kind) && !r.device.empty() && r.device != kTurntableId && r.device != kLightArcId) {
      return RuleName(i, r) + ": a stage is \"turntable\" or \"light_arc\"";
    }
  }
  return {};
}

core::CheckResult FaultPlan::Check(const formats::RigDescription& rig) const {
  if (auto problem = Check(); !problem.empty()) return problem;
  for (std::size_t i = 0; i < rules.size(); ++i) {
    const FaultRule& r = rules[i];
    if (r.device.empty()) continue;
    if (IsCameraKind(r.kind)) {
      const bool known =
          std::any_of(rig.cameras.begin(), rig.cameras.end(), [&](const auto& c) { return c.id == r.device; });
      if (!known) return RuleName(i, r) + ": rig " + core::Quoted(rig.name) + " has no such camera";
    }
    if (r.kind == FaultKind::kLampFailure && std::stoull(r.device) >= rig.lamps.elevations_rad.size()) {
      return RuleName(i, r) + ": rig \"" + rig.name + "\" has " + std::to_string(rig.lamps.elevations_rad.size()) +
             " lamps";
    }
  }
  return {};
}

FaultPlan ParseFaultPlan(const nlohmann::json& json, const std::filesystem::path& file, const std::string& where) {
  if (!json.is_object()) throw core::FormatError(file, where, "expected an object of fault kinds");
  return Parse(core::JsonFieldReader(json, file, where), false);
}

FaultPlan ReadFaultPlan(const std::filesystem::path& file) {
  const nlohmann::json json = core::ReadJsonFile(file, 16ull << 20);
  if (!json.is_object()) throw core::FormatError(file, "", "expected an object");
  return Parse(core::JsonFieldReader(json, file), true);
}

FaultPlan FaultPlanOfRig(const formats::RigDescription& rig) {
  if (!rig.json.is_object() || !rig.json.contains("faults")) return {};
  return ParseFaultPlan(rig.json["faults"], rig.file.empty() ? "rig " + core::Quoted(rig.name) : rig.file.string(),
                        "faults");
}

std::uint64_t FaultStreamSeed(std::uint64_t rig_seed, const std::string& device, FaultKind kind) {
  std::uint64_t h = Fnv1a(0xcbf29ce484222325ull, device);
  h = Fnv1a(h, "/");
  h = Fnv1a(h, ToString(kind));
  return Mix(Mix(rig_seed) ^ h);
}

FaultSchedule::FaultSchedule(const FaultPlan& plan, FaultKind kind, const std::string& device, std::uint64_t rig_seed)
    : random_(FaultStreamSeed(rig_seed, device, kind)) {
  double survive = 1.0;  // chance that no rate rule fires on one operation
  for (const FaultRule& r : plan.rules) {
    if (r.kind != kind || !(r.device.empty() || r.device == device)) continue;
    if (r.rate) survive *= 1.0 - *r.rate;
    at_.insert(at_.end(), r.at.begin(), r.at.end());
  }
  rate_ = 1.0 - survive;
  std::sort(at_.begin(), at_.end());
}

double FaultSchedule::Uniform() {
  // 53 random bits; std::uniform_real_distribution's output is not fixed by
  // the standard, and runs must repeat across standard libraries.
  return static_cast<double>(random_() >> 11) * 0x1.0p-53;
}

bool FaultSchedule::Fires() {
  ++operations_;
  bool fires = std::binary_search(at_.begin(), at_.end(), operations_);
  // Draw on every operation, fired or not, so one rule's firing does not
  // shift the stream of the next.
  if (rate_ > 0.0) fires = (Uniform() < rate_) || fires;
  return fires;
}

}  // namespace mesocap::sim
