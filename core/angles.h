// Degrees and radians (DESIGN.md "Conventions of the data": radians inside
// the code, degrees only in files and flags meant for people). One
// conversion for the whole tree, so that the same degrees give the same
// radians bit for bit everywhere, and degrees written from radians read
// back as the radians they came from (dividing by the same factor undoes
// the multiplication far more often than multiplying by 180 / pi does).
#pragma once

#include <numbers>

namespace mesocap::core {

inline constexpr double kRadiansPerDegree = std::numbers::pi / 180.0;

constexpr double RadiansFromDegrees(double degrees) { return degrees * kRadiansPerDegree; }
constexpr double DegreesFromRadians(double radians) { return radians / kRadiansPerDegree; }

// Calibration files (formats/calibration.h) have always been written as
// radians x (180 / pi) and read as degrees / (180 / pi), which for some
// angles is one ulp away from the pair above; the calibration keeps its own
// pair so that its files keep their bytes and read back exactly.
constexpr double CalibrationDegreesFromRadians(double radians) { return radians * (180.0 / std::numbers::pi); }
constexpr double CalibrationRadiansFromDegrees(double degrees) { return degrees / (180.0 / std::numbers::pi); }

}  // namespace mesocap::core
