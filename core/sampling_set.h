// Directions in the sample frame and the named sets of directions a BTF and
// an MDF are sampled on (docs/ARCHITECTURE.md "Conventions of the data": +z out of the
// sample, theta the polar angle from +z, phi the azimuth from +X towards +Y,
// directions point away from the surface).
#pragma once

#include <Eigen/Core>
#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/json_field_reader.h"

namespace mesocap::core {

struct SphericalAngles {
  double theta = 0.0;  // radians, [0, pi]
  double phi = 0.0;    // radians, [0, 2 pi)
};

Eigen::Vector3d DirectionFromAngles(double theta, double phi);
// Normalizes `d` (throws Error for a zero or non-finite vector). At the pole
// (|sin theta| < 1e-12) phi is 0.
SphericalAngles AnglesFromDirection(const Eigen::Vector3d& d);

// A set of directions on the upper hemisphere, organised in rings of equal
// polar angle (every set mesocap uses is: the rig's camera elevations and
// turntable azimuths, the Bonn domes, regular grids).
//
// Order: named sets and regular grids list their directions ring by ring from
// the pole outwards and, within a ring, by increasing phi in [0, 2 pi).
// FromAngles (and so ReadSamplingSet) keeps the order it is given, because a
// file's data is indexed by its own order.
//
// Weights: ring boundaries lie at the midpoints between consecutive ring
// thetas, the first band starts at 0 and the last ends at pi/2; a band's solid
// angle 2 pi (cos lo - cos hi) is shared equally by its ring's members. On a
// regular grid these are exactly the bands' solid angles.
class SamplingSet {
 public:
  // Core's named sets (docs/FORMATS.md "Sampling sets" gives every angle):
  //   "paper12x5", "paper12x8": the MDF paper's 12 azimuths x 5 or 8 polar
  //       angles; the paper gives no polar angles, so these are placed as in
  //       RegularGrid(12, 5) and RegularGrid(12, 8)
  //   "grid<A>x<P>": regular grid, A azimuths x P polar angles (e.g. "grid24x6")
  // The Bonn database's sets ("ubo2003", "ubo2014") are Bonn forms:
  // bonn::NamedSamplingSet (interop/bonn/ubo_sampling_sets.h) knows them and these.
  // FindNamed returns nullopt for any other name; Named throws Error listing
  // core's names. Both throw Error for a grid whose counts RegularGrid refuses.
  static std::optional<SamplingSet> FindNamed(const std::string& name);
  static SamplingSet Named(const std::string& name);
  // phi_k = 2 pi k / A, theta_j = (j + 0.5) (pi/2) / P: the centres of P equal
  // bands of [0, pi/2). Throws Error unless A >= 1, P >= 1, A * P <= 100,000 (what a file may hold).
  static SamplingSet RegularGrid(int azimuth_count, int polar_count);
  // Any directions (theta < pi/2), grouped into rings by equal theta (1e-9 rad).
  // Throws Error, naming the index, for a non-finite angle or a theta outside
  // [0, pi/2), for two directions closer than 1e-9 rad, and for an empty list.
  // phi is wrapped into [0, 2 pi) and set to 0 at the pole.
  static SamplingSet FromAngles(std::string name, const std::vector<SphericalAngles>& angles);

  const std::string& name() const { return name_; }
  int size() const { return static_cast<int>(angles_.size()); }
  const SphericalAngles& angles(int i) const { return angles_[i]; }
  const Eigen::Vector3d& direction(int i) const { return directions_[i]; }
  // Solid angle (sr) the direction stands for; the weights sum to 2 pi.
  double weight(int i) const { return weights_[i]; }

  // Index of the set direction closest in angle to `d`.
  int Nearest(const Eigen::Vector3d& d) const;

  // The same directions in the same order, each within `tolerance` (as a
  // distance of unit vectors, about the angle in radians).
  bool SameDirectionsAs(const SamplingSet& other, double tolerance) const;

  // Neighbours of `d` and weights (non-negative, summing to 1) to blend them:
  // linear in phi within the two rings that bracket theta, linear in theta
  // between them; clamped to the first/last ring outside their range.
  // Exact at the set's directions (one entry, weight 1); zero weights are left
  // out. A ring of one member (the pole) contributes that one sample.
  // Near the pole: with a pole sample the blend tends to it continuously as
  // theta -> 0. Without one (a regular grid), above the first ring the blend
  // is the first ring at d's phi, so it depends on phi however close d is to
  // the pole, and at the pole itself (phi = 0 by convention) it is the first
  // ring at phi 0.
  // At grazing: beyond the last ring (theta up to pi/2, and below the horizon
  // too) the blend is the last ring at d's phi, constant in theta; a function
  // that varies with theta there is reproduced only to first order in the gap.
  struct Blend {
    std::array<int, 4> index{};
    std::array<double, 4> weight{};
    int count = 0;
  };
  Blend Interpolate(const Eigen::Vector3d& d) const;

 private:
  struct Ring {
    double theta = 0.0;
    std::vector<int> members;  // indices into angles_, sorted by phi
    std::vector<double> phi;   // the members' phi, ascending, for binary search
  };
  void Build();  // rings, directions, weights from angles_
  // The members of `ring` either side of `phi` and the weight u of the upper
  // one (1 - u for the lower); `upper` is -1 for a ring of one member.
  struct RingBlend {
    int lower = 0;
    int upper = -1;
    double u = 0.0;
  };
  RingBlend BlendOnRing(const Ring& ring, double phi) const;

  std::string name_;
  std::vector<SphericalAngles> angles_;
  std::vector<Eigen::Vector3d> directions_;
  std::vector<double> weights_;
  std::vector<Ring> rings_;
};

// JSON form (docs/FORMATS.md "Sampling sets"): {"name": ..., "directions_deg":
// [[theta, phi], ...]}. Named sets are stored with their directions too, so
// a reader never needs mesocap's table of names. ReadSamplingSet takes the
// reader of the set's object and accepts 1 to 100000 entries, each a pair of
// finite numbers with theta in [0, 90); failures throw FormatError naming the
// field ("view_directions.directions_deg[3]").
nlohmann::json ToJson(const SamplingSet& set);
SamplingSet ReadSamplingSet(const JsonFieldReader& fields);

}  // namespace mesocap::core
