// A lamp's highlight on the mirror sphere: where a camera sees it, and
// where a point lamp's would be. The lamps' calibration
// (calibration/light_arc_calibration.h) back-projects the highlight's pixels
// and reflects them off the sphere; the point lamp's is its forward model.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/image.h"

namespace mesocap::calibration {

struct SphereHighlightOptions {
  // Below this peak (fraction of full scale) the image holds no highlight.
  double min_peak = 0.02;
  // The highlight's pixels are those within this radius (pixels) of the
  // brightest, with their signal above background_fraction of the peak.
  int window_radius_px = 6;
  double background_fraction = 0.01;
  // A pixel at least this bright is saturated (or nearly).
  double saturation = 0.98;
  core::CheckResult Check() const;
};

struct HighlightPixel {
  int x = 0, y = 0;
  double signal = 0.0;  // above the background
};

struct SphereHighlight {
  // The centroid of the pixels' signal; pixel (i, j) centred at (i, j). An
  // extended lamp's centroid is not its centre's reflection (the mirror
  // magnifies one side of its image more than the other), so the lamps'
  // calibration uses the pixels themselves.
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  std::vector<HighlightPixel> pixels;
  double peak = 0.0;  // brightest value, fraction of full scale
  int saturated_pixels = 0;
  // Non-empty when the image is no use: a second highlight beyond the
  // window (another bright reflection: which one is the lamp's?), or the
  // highlight cut by the image's edge.
  std::string problem;
};

// The highlight of an image (any channel count: their mean); nullopt when
// nothing reaches min_peak. Throws Error on bad options.
std::optional<SphereHighlight> FindSphereHighlight(const core::Image& image,
                                                   const SphereHighlightOptions& options = {});

// The point of a mirror sphere (centre, radius) where an eye sees a point
// lamp's reflection: in the plane of the centre, eye and lamp, the normal
// that halves the angle between the directions to the two, found by
// bisection to 1e-13 rad. The eye and lamp must lie outside the sphere;
// a lamp straight behind the sphere (their directions from the centre
// opposite) has no such point, and gives nullopt.
std::optional<Eigen::Vector3d> SpecularPoint(const Eigen::Vector3d& centre, double radius, const Eigen::Vector3d& eye,
                                             const Eigen::Vector3d& lamp);

}  // namespace mesocap::calibration
