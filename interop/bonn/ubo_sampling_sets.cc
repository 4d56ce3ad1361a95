#include "interop/bonn/ubo_sampling_sets.h"

#include <optional>
#include <vector>

#include "core/angles.h"
#include "core/error.h"

namespace mesocap::bonn {
namespace {

const char* const kValidNames =
    "\"paper12x5\", \"paper12x8\", \"ubo2003\", \"ubo2014\", \"grid<A>x<P>\" (e.g. \"grid24x6\")";

// A ring of `count` directions at `theta_deg`, azimuths offset + 360 k / count.
struct RingSpec {
  double theta_deg;
  int count;
  double offset_deg;
};

std::vector<core::SphericalAngles> RingAngles(const std::vector<RingSpec>& rings) {
  std::vector<core::SphericalAngles> out;
  for (const auto& r : rings) {
    for (int k = 0; k < r.count; ++k) {
      out.push_back(
          {core::RadiansFromDegrees(r.theta_deg), core::RadiansFromDegrees(r.offset_deg + 360.0 * k / r.count)});
    }
  }
  return out;
}

}  // namespace

core::SamplingSet NamedSamplingSet(const std::string& name) {
  // Sattler, Sarlette, Klein 2003: six rings 15 degrees apart.
  if (name == "ubo2003") {
    return core::SamplingSet::FromAngles(
        name, RingAngles({{0, 1, 0}, {15, 6, 0}, {30, 12, 0}, {45, 18, 0}, {60, 20, 0}, {75, 24, 0}}));
  }
  // Bonn dome 1 as in btflib's create_ubo_dome1_sampling (ring offsets included).
  if (name == "ubo2014") {
    return core::SamplingSet::FromAngles(name, RingAngles({{0, 1, 0},
                                                           {11, 6, 15},
                                                           {23.5, 12, 0},
                                                           {30, 12, 15},
                                                           {37.5, 12, 0},
                                                           {45, 18, 0},
                                                           {52.5, 18, 7.5},
                                                           {60, 24, 0},
                                                           {67.5, 24, 7.5},
                                                           {75, 24, 0}}));
  }
  if (std::optional<core::SamplingSet> set = core::SamplingSet::FindNamed(name)) return *std::move(set);
  throw core::Error("unknown sampling set " + core::Quoted(name) + "; valid names: " + kValidNames);
}

}  // namespace mesocap::bonn
