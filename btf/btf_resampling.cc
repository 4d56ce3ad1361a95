#include "btf/btf_resampling.h"

#include <algorithm>
#include <numeric>

#include "core/error.h"

namespace mesocap::btf {

CapturedDirections MakeCapturedDirections(const std::string& what, const std::vector<Eigen::Vector3d>& centre,
                                          double ring_tolerance_rad) {
  if (centre.empty()) throw core::Error(what + ": no captured directions");
  std::vector<core::SphericalAngles> angles;
  for (const Eigen::Vector3d& d : centre) angles.push_back(core::AnglesFromDirection(d));
  // Rings: sorted thetas split where consecutive ones differ by more than
  // the tolerance; each ring takes its members' mean theta.
  std::vector<int> order(angles.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return angles[a].theta < angles[b].theta; });
  for (std::size_t begin = 0; begin < order.size();) {
    std::size_t end = begin + 1;
    while (end < order.size() && angles[order[end]].theta - angles[order[end - 1]].theta <= ring_tolerance_rad) ++end;
    double mean = 0.0;
    for (std::size_t k = begin; k < end; ++k) mean += angles[order[k]].theta;
    mean /= static_cast<double>(end - begin);
    for (std::size_t k = begin; k < end; ++k) angles[order[k]].theta = mean;
    begin = end;
  }
  CapturedDirections out;
  try {
    out.nominal = core::SamplingSet::FromAngles(what, angles);
  } catch (const core::Error& e) {
    throw core::Error(what + ": captured directions do not form a set (" + e.what() + ")");
  }
  for (int i = 0; i < out.nominal.size(); ++i) out.offset.push_back(centre[i].normalized() - out.nominal.direction(i));
  out.first_ring_theta = angles[order.front()].theta;
  out.last_ring_theta = angles[order.back()].theta;
  return out;
}

}  // namespace mesocap::btf
