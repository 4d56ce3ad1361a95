// Faults on demand for the simulated rig: which device fails how, at a rate
// or at given steps, so capture code can be tested against the failures a
// real rig has overnight (dropped frames, timeouts, disconnects, stalled
// stages, burnt-out lamps).
//
// In JSON (a rig description's optional "faults" member, or a file of its
// own with "format": "mesocap.faults", "version": 1), one member per fault
// kind, each one rule or a list of rules:
//
//   "faults": {
//     "camera_drop_frame": {"rate": 0.01},
//     "stage_stall": {"device": "turntable", "at": [3]},
//     "lamp_failure": [{"device": 2, "at": [1]}, {"rate": 0.001}]
//   }
//
// A rule has either "rate" (the probability that one operation fails, in
// [0, 1]) or "at" (the operation counts, from 1, at which it fails), and an
// optional "device" (a camera id; "turntable" or "light_arc"; a lamp index);
// without it the rule applies to every device of its kind, each counting on
// its own. What one operation is, per kind:
//
//   camera_drop_frame  a frame the camera exposes: the frame is lost, its
//                      sequence number is skipped, Grab returns the next one
//   camera_timeout     a Grab: it throws TimeoutError, the frame is lost
//   camera_disconnect  a call to the camera (setters, Trigger, Grab): it and
//                      every later call throw DisconnectedError
//   stage_stall        a move (Home or MoveTo): the stage stops part way, at a
//                      position its controller does not know, and is no
//                      longer homed; Home / WaitUntilStopped throw StallError
//   stage_timeout      a move: its controller does not answer in time; Home /
//                      WaitUntilStopped throw TimeoutError, a retry succeeds
//   lamp_failure       switching a lamp on: it throws LampFailureError and
//                      the lamp stays dead
//
// Every (device, kind) pair draws from its own std::mt19937_64, seeded from
// the rig's seed, the device id and the kind, so a run is the same for the
// same seed whatever order the devices are used in.
#pragma once

#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "core/enum_text.h"
#include "core/error.h"
#include "formats/rig_description.h"

namespace mesocap::sim {

enum class FaultKind {
  kCameraDropFrame,
  kCameraTimeout,
  kCameraDisconnect,
  kStageStall,
  kStageTimeout,
  kLampFailure,
};

inline constexpr FaultKind kAllFaultKinds[] = {
    FaultKind::kCameraDropFrame, FaultKind::kCameraTimeout, FaultKind::kCameraDisconnect,
    FaultKind::kStageStall,      FaultKind::kStageTimeout,  FaultKind::kLampFailure,
};

constexpr auto EnumNamesOf(FaultKind) {
  return std::to_array(
      {"camera_drop_frame", "camera_timeout", "camera_disconnect", "stage_stall", "stage_timeout", "lamp_failure"});
}
using core::ToString;

// The device ids faults name: cameras by their id, the stages as below,
// lamps by their index (LampDeviceId).
inline constexpr std::string_view kTurntableId = "turntable";
inline constexpr std::string_view kLightArcId = "light_arc";
std::string LampDeviceId(int lamp);

struct FaultRule {
  FaultKind kind = FaultKind::kCameraDropFrame;
  std::string device;             // empty: every device of the kind
  std::optional<double> rate;     // per operation, in [0, 1]
  std::vector<std::uint64_t> at;  // operation counts from 1
};

struct FaultPlan {
  std::vector<FaultRule> rules;

  bool empty() const { return rules.empty(); }
  // A rule has exactly one of rate / at; rates in [0, 1]; counts from 1;
  // a lamp device is a lamp index. Empty when valid.
  core::CheckResult Check() const;
  // Check(), and that every device a rule names exists in `rig`, so a
  // misspelt camera id does not silently never fail.
  core::CheckResult Check(const formats::RigDescription& rig) const;
};

// Parses the object described above; errors name the file and the field.
// `where` is the object's path in the document ("faults" in a rig).
FaultPlan ParseFaultPlan(const nlohmann::json& json, const std::filesystem::path& file, const std::string& where = "");
// A file of its own ("format": "mesocap.faults", "version": 1).
FaultPlan ReadFaultPlan(const std::filesystem::path& file);
// The rig description's "faults" member, or an empty plan without one.
FaultPlan FaultPlanOfRig(const formats::RigDescription& rig);

// When one kind of fault fires on one device: counts the device's
// operations and draws against the rules that apply to it.
class FaultSchedule {
 public:
  FaultSchedule() = default;  // never fires
  FaultSchedule(const FaultPlan& plan, FaultKind kind, const std::string& device, std::uint64_t rig_seed);

  // Counts one operation; true when the fault fires on it.
  bool Fires();
  std::uint64_t operations() const { return operations_; }
  // A uniform number in [0, 1) from this schedule's stream, for where a
  // fault leaves the device (how far a stalled stage got).
  double Uniform();

 private:
  double rate_ = 0.0;              // the rate rules combined
  std::vector<std::uint64_t> at_;  // sorted
  std::uint64_t operations_ = 0;
  std::mt19937_64 random_;
};

// The seed of one (device, kind) stream: a fixed hash (not std::hash, which
// may differ between standard libraries) mixed with the rig's seed.
std::uint64_t FaultStreamSeed(std::uint64_t rig_seed, const std::string& device, FaultKind kind);

}  // namespace mesocap::sim
