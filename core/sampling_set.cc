#include "core/sampling_set.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <numeric>
#include <sstream>

#include "core/angles.h"
#include "core/error.h"

namespace mesocap::core {
namespace {

constexpr double kPi = std::numbers::pi;
// Thetas closer than this form one ring; directions closer than this coincide.
constexpr double kRingTolerance = 1e-9;
// A direction this close (rad) to a ring, or to a member in phi, counts as on
// it, so that Interpolate is exact at the set's directions despite the
// rounding of the angle <-> direction conversions (about 1e-15).
constexpr double kSnap = 1e-10;
// The same bound as a file may hold, so every set can be stored and read back.
constexpr std::int64_t kMaxGridDirections = 100'000;
constexpr std::size_t kMaxFileDirections = 100'000;

const char* const kValidNames = "\"paper12x5\", \"paper12x8\", \"grid<A>x<P>\" (e.g. \"grid24x6\")";

double WrapPhi(double phi) {
  double p = std::fmod(phi, kTwoPi);
  if (p < 0.0) p += kTwoPi;
  if (p >= kTwoPi) p = 0.0;  // -tiny + 2 pi rounds to 2 pi
  return p;
}

// atan2 keeps full precision for small angles, where acos(dot) loses half the digits.
double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

std::string Degrees(double radians) {
  std::ostringstream s;
  s.precision(12);
  s << DegreesFromRadians(radians);
  return s.str();
}

// "grid<A>x<P>" with both counts in canonical decimal form (no sign, no
// leading zeros), so that every grid has exactly one name.
bool ParseGridName(const std::string& name, int* azimuths, int* polars) {
  if (!name.starts_with("grid")) return false;
  const auto x = name.find('x', 4);
  if (x == std::string::npos) return false;
  const char* a_end = name.data() + x;
  const char* p_end = name.data() + name.size();
  const auto a = std::from_chars(name.data() + 4, a_end, *azimuths);
  const auto p = std::from_chars(a_end + 1, p_end, *polars);
  if (a.ec != std::errc() || a.ptr != a_end || p.ec != std::errc() || p.ptr != p_end) return false;
  return name == "grid" + std::to_string(*azimuths) + "x" + std::to_string(*polars);
}

}  // namespace

Eigen::Vector3d DirectionFromAngles(double theta, double phi) {
  if (!std::isfinite(theta) || !std::isfinite(phi)) throw Error("direction angles must be finite");
  const double s = std::sin(theta);
  return {s * std::cos(phi), s * std::sin(phi), std::cos(theta)};
}

SphericalAngles AnglesFromDirection(const Eigen::Vector3d& d) {
  if (!d.allFinite()) throw Error("direction must be finite");
  const double norm = d.norm();
  if (!(norm > 0.0)) throw Error("direction must not be zero");
  const double rho = std::hypot(d.x(), d.y());
  SphericalAngles a;
  a.theta = std::atan2(rho, d.z());  // accurate near the pole, unlike acos(z)
  a.phi = rho / norm < 1e-12 ? 0.0 : WrapPhi(std::atan2(d.y(), d.x()));
  return a;
}

std::optional<SamplingSet> SamplingSet::FindNamed(const std::string& name) {
  // The MDF paper (Wang et al. 2005, Table 1) gives only the counts 12 x 5 and
  // 12 x 8, not the polar angles; they are placed as in RegularGrid.
  if (name == "paper12x5" || name == "paper12x8") {
    SamplingSet set = RegularGrid(12, name == "paper12x5" ? 5 : 8);
    set.name_ = name;
    return set;
  }
  int azimuths = 0;
  int polars = 0;
  if (ParseGridName(name, &azimuths, &polars)) return RegularGrid(azimuths, polars);
  return std::nullopt;
}

SamplingSet SamplingSet::Named(const std::string& name) {
  if (std::optional<SamplingSet> set = FindNamed(name)) return *std::move(set);
  throw Error("unknown sampling set " + Quoted(name) + "; valid names: " + kValidNames);
}

SamplingSet SamplingSet::RegularGrid(int azimuth_count, int polar_count) {
  if (azimuth_count < 1 || polar_count < 1 || std::int64_t{azimuth_count} * polar_count > kMaxGridDirections) {
    throw Error("regular grid of " + std::to_string(azimuth_count) + " azimuths x " + std::to_string(polar_count) +
                " polar angles: expected at least 1 of each and at most " + std::to_string(kMaxGridDirections) +
                " directions");
  }
  std::vector<SphericalAngles> angles;
  angles.reserve(static_cast<std::size_t>(azimuth_count) * polar_count);
  for (int j = 0; j < polar_count; ++j) {
    for (int k = 0; k < azimuth_count; ++k) {
      angles.push_back({(j + 0.5) * (kPi / 2) / polar_count, kTwoPi * k / azimuth_count});
    }
  }
  return FromAngles("grid" + std::to_string(azimuth_count) + "x" + std::to_string(polar_count), angles);
}

SamplingSet SamplingSet::FromAngles(std::string name, const std::vector<SphericalAngles>& angles) {
  const std::string where = "sampling set " + Quoted(name) + ": ";
  if (angles.empty()) throw Error(where + "no directions");
  SamplingSet set;
  set.name_ = std::move(name);
  set.angles_.reserve(angles.size());
  for (std::size_t i = 0; i < angles.size(); ++i) {
    const SphericalAngles& a = angles[i];
    if (!std::isfinite(a.theta) || !std::isfinite(a.phi)) {
      throw Error(where + "direction " + std::to_string(i) + " has a non-finite angle");
    }
    if (a.theta < 0.0 || a.theta >= kPi / 2) {
      throw Error(where + "direction " + std::to_string(i) + " has theta " + Degrees(a.theta) +
                  " degrees; expected [0, 90)");
    }
    set.angles_.push_back({a.theta, std::sin(a.theta) < 1e-12 ? 0.0 : WrapPhi(a.phi)});
  }
  try {
    set.Build();
  } catch (const Error& e) {
    throw Error(where + e.what());
  }
  return set;
}

void SamplingSet::Build() {
  const int n = size();
  std::vector<int> by_theta(n);
  std::iota(by_theta.begin(), by_theta.end(), 0);
  std::stable_sort(by_theta.begin(), by_theta.end(), [&](int a, int b) { return angles_[a].theta < angles_[b].theta; });

  // A ring takes every theta within the tolerance of its smallest one, and its
  // members take that theta, so a ring has one theta exactly.
  rings_.clear();
  for (int i : by_theta) {
    if (rings_.empty() || angles_[i].theta - rings_.back().theta > kRingTolerance) {
      rings_.push_back(Ring{angles_[i].theta, {}, {}});
    }
    angles_[i].theta = rings_.back().theta;
    rings_.back().members.push_back(i);
  }

  directions_.resize(n);
  for (int i = 0; i < n; ++i) directions_[i] = DirectionFromAngles(angles_[i].theta, angles_[i].phi);

  for (Ring& ring : rings_) {
    std::stable_sort(ring.members.begin(), ring.members.end(),
                     [&](int a, int b) { return angles_[a].phi < angles_[b].phi; });
    ring.phi.clear();
    for (int m : ring.members) ring.phi.push_back(angles_[m].phi);
    // Within a ring the closest pairs are neighbours in phi (the last and the
    // first are neighbours across phi = 0).
    const std::size_t count = ring.members.size();
    for (std::size_t k = 0; count > 1 && k < count; ++k) {
      const int a = ring.members[k];
      const int b = ring.members[(k + 1) % count];
      if (AngleBetween(directions_[a], directions_[b]) < kRingTolerance) {
        throw Error("directions " + std::to_string(std::min(a, b)) + " and " + std::to_string(std::max(a, b)) +
                    " coincide (closer than 1e-9 rad)");
      }
    }
  }

  weights_.assign(n, 0.0);
  for (std::size_t r = 0; r < rings_.size(); ++r) {
    const double lo = r == 0 ? 0.0 : 0.5 * (rings_[r - 1].theta + rings_[r].theta);
    const double hi = r + 1 == rings_.size() ? kPi / 2 : 0.5 * (rings_[r].theta + rings_[r + 1].theta);
    const double share = kTwoPi * (std::cos(lo) - std::cos(hi)) / static_cast<double>(rings_[r].members.size());
    for (int m : rings_[r].members) weights_[m] = share;
  }
}

SamplingSet::RingBlend SamplingSet::BlendOnRing(const Ring& ring, double phi) const {
  const std::size_t count = ring.members.size();
  if (count == 1) return {ring.members[0], -1, 0.0};
  // The members either side of phi; below the first or beyond the last member
  // the pair is (last, first), across phi = 0.
  std::size_t hi = std::upper_bound(ring.phi.begin(), ring.phi.end(), phi) - ring.phi.begin();
  const std::size_t lo = hi == 0 ? count - 1 : hi - 1;
  if (hi == count) hi = 0;
  const double gap = WrapPhi(ring.phi[hi] - ring.phi[lo]);
  const double offset = WrapPhi(phi - ring.phi[lo]);
  double u = std::clamp(offset / gap, 0.0, 1.0);
  if (offset <= kSnap) u = 0.0;
  if (gap - offset <= kSnap) u = 1.0;
  return {ring.members[lo], ring.members[hi], u};
}

bool SamplingSet::SameDirectionsAs(const SamplingSet& other, double tolerance) const {
  if (size() != other.size()) return false;
  for (int i = 0; i < size(); ++i) {
    if ((direction(i) - other.direction(i)).norm() > tolerance) return false;
  }
  return true;
}

int SamplingSet::Nearest(const Eigen::Vector3d& d) const {
  const SphericalAngles a = AnglesFromDirection(d);
  const Eigen::Vector3d u = d.normalized();
  const int ring_count = static_cast<int>(rings_.size());

  int best = -1;
  double best_angle = std::numeric_limits<double>::infinity();
  // On one ring the angle to a member grows with its phi distance, so only the
  // two members either side of phi can be the closest.
  auto visit = [&](const Ring& ring) {
    const RingBlend pair = BlendOnRing(ring, a.phi);
    for (int m : {pair.lower, pair.upper}) {
      if (m < 0) continue;
      const double angle = AngleBetween(u, directions_[m]);
      if (angle < best_angle) {
        best_angle = angle;
        best = m;
      }
    }
  };

  // |theta - ring theta| bounds from below the angle to any member of a ring:
  // visit rings outwards from theta and stop once that bound passes the best.
  int above = static_cast<int>(
      std::lower_bound(rings_.begin(), rings_.end(), a.theta, [](const Ring& r, double t) { return r.theta < t; }) -
      rings_.begin());
  int below = above - 1;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  while (below >= 0 || above < ring_count) {
    const double gap_below = below >= 0 ? a.theta - rings_[below].theta : kInf;
    const double gap_above = above < ring_count ? rings_[above].theta - a.theta : kInf;
    if (std::min(gap_below, gap_above) > best_angle + 1e-12) break;
    if (gap_below <= gap_above) {
      visit(rings_[below--]);
    } else {
      visit(rings_[above++]);
    }
  }
  return best;
}

SamplingSet::Blend SamplingSet::Interpolate(const Eigen::Vector3d& d) const {
  const SphericalAngles a = AnglesFromDirection(d);
  Blend blend;
  auto add = [&](int index, double weight) {
    if (weight <= 0.0) return;
    blend.index[blend.count] = index;
    blend.weight[blend.count] = weight;
    ++blend.count;
  };
  auto add_ring = [&](const Ring& ring, double weight) {
    const RingBlend pair = BlendOnRing(ring, a.phi);
    add(pair.lower, weight * (1.0 - pair.u));
    if (pair.upper >= 0) add(pair.upper, weight * pair.u);
  };

  // The first ring with theta above d's; the one before it is at or below.
  const auto upper =
      std::upper_bound(rings_.begin(), rings_.end(), a.theta, [](double t, const Ring& r) { return t < r.theta; });
  if (upper == rings_.begin()) {
    add_ring(rings_.front(), 1.0);  // above the first ring: clamp
  } else if (upper == rings_.end()) {
    add_ring(rings_.back(), 1.0);  // beyond the last ring (grazing): clamp
  } else {
    const Ring& r0 = *(upper - 1);
    const Ring& r1 = *upper;
    double s = (a.theta - r0.theta) / (r1.theta - r0.theta);
    if (a.theta - r0.theta <= kSnap) s = 0.0;
    if (r1.theta - a.theta <= kSnap) s = 1.0;
    add_ring(r0, 1.0 - s);
    add_ring(r1, s);
  }
  return blend;
}

nlohmann::json ToJson(const SamplingSet& set) {
  nlohmann::json directions = nlohmann::json::array();
  for (int i = 0; i < set.size(); ++i) {
    directions.push_back(
        nlohmann::json::array({DegreesFromRadians(set.angles(i).theta), DegreesFromRadians(set.angles(i).phi)}));
  }
  return {{"name", set.name()}, {"directions_deg", std::move(directions)}};
}

SamplingSet ReadSamplingSet(const JsonFieldReader& fields) {
  fields.RejectUnknownMembers({"name", "directions_deg"});
  const std::string name = fields.String("name");
  const nlohmann::json& list = fields.Raw("directions_deg");
  if (!list.is_array()) {
    fields.Fail("directions_deg", "expected a list of [theta, phi] pairs in degrees, got " + JsonExcerpt(list));
  }
  if (list.empty() || list.size() > kMaxFileDirections) {
    fields.Fail("directions_deg", "expected 1 to " + std::to_string(kMaxFileDirections) + " directions, got " +
                                      std::to_string(list.size()));
  }
  std::vector<SphericalAngles> angles;
  angles.reserve(list.size());
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string key = "directions_deg[" + std::to_string(i) + "]";
    const nlohmann::json& entry = list[i];
    const bool pair = entry.is_array() && entry.size() == 2 && entry[0].is_number() && entry[1].is_number() &&
                      std::isfinite(entry[0].get<double>()) && std::isfinite(entry[1].get<double>());
    if (!pair) {
      fields.Fail(key, "expected a pair of finite numbers [theta, phi] in degrees, got " + JsonExcerpt(entry));
    }
    const double theta_deg = entry[0].get<double>();
    if (theta_deg < 0.0 || theta_deg >= 90.0) {
      fields.Fail(key, "theta " + JsonExcerpt(entry[0]) + " degrees is outside [0, 90)");
    }
    angles.push_back({RadiansFromDegrees(theta_deg), RadiansFromDegrees(entry[1].get<double>())});
  }
  try {
    return SamplingSet::FromAngles(name, angles);
  } catch (const Error& e) {
    // Coinciding directions; the message names their indices in the list.
    fields.Fail("directions_deg", e.what());
  }
}

}  // namespace mesocap::core
