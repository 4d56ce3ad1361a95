// Degrees and radians (docs/ARCHITECTURE.md "Conventions of the data": radians inside
// the code, degrees only in files and flags meant for people). One
// conversion for the whole tree, so that the same degrees give the same
// radians bit for bit everywhere, and degrees written from radians read
// back as the radians they came from (dividing by the same factor undoes
// the multiplication far more often than multiplying by 180 / pi does).
#pragma once

#include <numbers>

namespace mesocap::core {

inline constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;
inline constexpr double kTwoPi = 2.0 * std::numbers::pi;  // one turn, radians

constexpr double RadiansFromDegrees(double degrees) { return degrees * kRadiansPerDegree; }
constexpr double DegreesFromRadians(double radians) { return radians / kRadiansPerDegree; }

}  // namespace mesocap::core
