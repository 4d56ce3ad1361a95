// Laser line detection and the two-height laser-plane calibration (MDF paper
// Sec. 3.2), against the simulated rig's exact laser planes
// (sim/camera_renderer.h LaserPlaneAt).
#include "calibration/laser_plane_calibration.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include "calibration/laser_line.h"
#include "calibration/nominal_geometry.h"
#include "calibration/rig_frames.h"
#include "core/plane.h"
#include "formats/rig_description.h"
#include "mdf/laser_sweep.h"
#include "sim/camera_renderer.h"
#include "sim/camera_sensor.h"
#include "sim/laser_sweep_renderer.h"
#include "tests/common/flat_small_rig.h"

namespace mesocap::calibration {
namespace {

class LaserGeometryTest : public testing::FlatSmallRigTest {
 protected:
  core::Image Sense(const core::Image& signal, int cam, std::uint64_t k) const {
    std::mt19937_64 rng = sim::ImageNoiseGenerator(11, {k});
    return sim::ApplySensor(signal, rig_.cameras[cam], rng, true);
  }
  // The stripe of laser location `li` on the two calibration plates as camera
  // `cam` sees it, before the sensor.
  std::array<core::Image, 2> PlateSignals(int li, int cam) const {
    const auto& loc = rig_.laser.locations[li];
    std::array<core::Image, 2> signals;
    for (int h = 0; h < 2; ++h) {
      const sim::CameraView plate = renderer_.TracePlate(cam, rig_.laser.calibration_heights_mm[h]);
      signals[h] = sim::LaserSweepRenderer(renderer_, plate, loc.mount, loc.arc_angle_rad).Frame(0.0);
    }
    return signals;
  }
};

// Distance (mm) of the true plane's trace on z = height from a detected
// line, at the line's point and 10 mm along it.
double TraceError(const sim::LaserPlane& truth, const ReferenceLine& line) {
  double worst = 0;
  for (double s : {-10.0, 0.0, 10.0}) {
    const Eigen::Vector3d p(line.point.x() + s * line.direction.x(), line.point.y() + s * line.direction.y(),
                            line.height);
    worst = std::max(worst, std::abs(truth.normal.dot(p - truth.source)));
  }
  return worst;
}

TEST_F(LaserGeometryTest, DetectsTheStripeOnTheReferencePlaneToSubPixel) {
  const int cam = 1;
  const CameraRays rays(calibration_.cameras[cam]);
  const core::RigidTransform world_from_sample = WorldFromSample(calibration_.turntable, 0.0);
  const PixelMask region = mdf::ReferenceRegion(rays, world_from_sample, rig_.sample_size_mm, 1.0, 30.0);
  const sim::CameraView view = renderer_.TraceSample(cam, 0.0);
  for (int li : {0, 4, 6}) {
    const auto& loc = rig_.laser.locations[li];
    const sim::LaserSweepRenderer sweep(renderer_, view, loc.mount, loc.arc_angle_rad);
    const LaserMountPose pose = MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, 0.0);
    for (double offset : {-12.0, 0.0, 9.0}) {
      const double tilt = LaserTiltForOffset(rig_.laser, loc.mount, offset);
      const ReferenceLine line =
          DetectLaserLine(Sense(sweep.Frame(tilt), cam, li * 100 + static_cast<int>(offset + 50)), region, rays, 0.0,
                          pose.normal.head<2>().normalized(), {});
      ASSERT_TRUE(line.valid) << li << " " << offset;
      // A pixel covers ~0.25 mm here; the line is good to a few hundredths.
      EXPECT_LT(TraceError(renderer_.LaserPlaneAt(loc.mount, loc.arc_angle_rad, tilt), line), 0.03)
          << "location " << li << " offset " << offset;
      EXPECT_GT(line.inliers, 50);
    }
  }
}

TEST_F(LaserGeometryTest, NoStripeInTheReferenceRegionGivesNoLine) {
  const int cam = 0;
  const CameraRays rays(calibration_.cameras[cam]);
  const PixelMask region =
      mdf::ReferenceRegion(rays, WorldFromSample(calibration_.turntable, 0.0), rig_.sample_size_mm, 1.0, 30.0);
  const core::Image dark = Sense(core::Image(rays.width(), rays.height(), 1, 0.0f), cam, 1);
  EXPECT_FALSE(DetectLaserLine(dark, region, rays, 0.0, {1, 0}, {}).valid);
}

TEST_F(LaserGeometryTest, TwoHeightCalibrationRecoversThePlaneAngle) {
  for (int li : {0, 4, 7}) {  // one per mount (45, 67.5, 84.375 degrees)
    const auto& loc = rig_.laser.locations[li];
    const int cam = 2;
    const CameraRays rays(calibration_.cameras[cam]);
    const std::array<core::Image, 2> signals = PlateSignals(li, cam);
    const core::Image plates[2] = {Sense(signals[0], cam, 500 + 2 * li), Sense(signals[1], cam, 501 + 2 * li)};
    const LaserMountPose pose = MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, 0.0);
    const core::Plane plane = CalibrateLaserPlane(plates[0], rig_.laser.calibration_heights_mm[0], plates[1],
                                                  rig_.laser.calibration_heights_mm[1], rays,
                                                  pose.normal.head<2>().normalized(), 30.0, {}, "test")
                                  .plane;
    const sim::LaserPlane truth = renderer_.LaserPlaneAt(loc.mount, loc.arc_angle_rad, 0.0);
    // Sec. 3.2's angle between laser plane and reference plane.
    const double true_angle = std::acos(std::abs(truth.normal.z()));
    EXPECT_NEAR(AngleToReferencePlane(plane), true_angle, 0.1 * std::numbers::pi / 180) << "location " << li;
    EXPECT_GT(std::abs(plane.normal.dot(truth.normal)), std::cos(0.1 * std::numbers::pi / 180));
    EXPECT_LT(std::abs(plane.SignedDistance(truth.source)), 2.0);  // 700 mm away, 0.1 degree ~ 1.2 mm
  }
  // A stripe missing from one plate is an error naming the location.
  const CameraRays rays(calibration_.cameras[0]);
  const core::Image dark(rays.width(), rays.height(), 1, 0.0f);
  EXPECT_THROW(CalibrateLaserPlane(dark, 0.0, dark, 10.0, rays, {1, 0}, 30.0, {}, "location 0"), core::Error);
}

// The planes' sigmas against their errors over sensor-noise seeds. The
// sigmas model the noise: the position's scatter about its mean over the
// seeds, and the normal's error, divided by the sigmas, have an RMS near 1.
// What the noise does not move, the bias of the stripe's profile against the
// pixel grid, is not in the sigma; it is bounded here. The plates are
// rendered once; only the noise changes.
TEST_F(LaserGeometryTest, PlaneSigmasMatchTheErrorsOverNoiseSeeds) {
  constexpr int kSeeds = 8;
  double scatter_ratio2 = 0, normal_ratio2 = 0, worst_bias = 0, worst_height_sigma = 0;
  int n = 0;
  for (int li : {0, 4, 7}) {
    const auto& loc = rig_.laser.locations[li];
    const int cam = 2;
    const CameraRays rays(calibration_.cameras[cam]);
    const std::array<core::Image, 2> signal = PlateSignals(li, cam);
    const LaserMountPose pose = MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, 0.0);
    const sim::LaserPlane truth = renderer_.LaserPlaneAt(loc.mount, loc.arc_angle_rad, 0.0);
    std::vector<double> position_errors, position_sigmas;
    for (int seed = 0; seed < kSeeds; ++seed) {
      const LaserPlaneFit fit =
          CalibrateLaserPlane(Sense(signal[0], cam, 1000 + 10 * li + 2 * seed), rig_.laser.calibration_heights_mm[0],
                              Sense(signal[1], cam, 1001 + 10 * li + 2 * seed), rig_.laser.calibration_heights_mm[1],
                              rays, pose.normal.head<2>().normalized(), 30.0, {}, "test");
      ASSERT_GT(fit.position_sigma_mm, 0.0);
      ASSERT_GT(fit.normal_sigma_rad, 0.0);
      position_errors.push_back(truth.normal.dot(fit.anchor - truth.source));
      position_sigmas.push_back(fit.position_sigma_mm);
      const double normal_error = std::acos(std::min(1.0, std::abs(fit.plane.normal.dot(truth.normal))));
      normal_ratio2 += std::pow(normal_error / fit.normal_sigma_rad, 2);
      worst_height_sigma = std::max(worst_height_sigma, fit.height_sigma_mm);
      ++n;
    }
    double bias = 0;
    for (double e : position_errors) bias += e / kSeeds;
    double scatter2 = 0, sigma2 = 0;
    for (int seed = 0; seed < kSeeds; ++seed) {
      scatter2 += std::pow(position_errors[seed] - bias, 2) / (kSeeds - 1);
      sigma2 += std::pow(position_sigmas[seed], 2) / kSeeds;
    }
    std::printf("location %d: position bias %.6f mm, scatter %.6f mm, sigma %.6f mm\n", li, bias, std::sqrt(scatter2),
                std::sqrt(sigma2));
    scatter_ratio2 += scatter2 / sigma2 / 3;
    worst_bias = std::max(worst_bias, std::abs(bias));
  }
  const double scatter_rms = std::sqrt(scatter_ratio2), normal_rms = std::sqrt(normal_ratio2 / n);
  std::printf("scatter / sigma RMS: position %.2f; errors / sigma RMS: normal %.2f; height sigma up to %.4f mm\n",
              scatter_rms, normal_rms, worst_height_sigma);
  EXPECT_GT(scatter_rms, 0.3);
  EXPECT_LT(scatter_rms, 2.0);
  EXPECT_GT(normal_rms, 0.5);
  EXPECT_LT(normal_rms, 2.0);
  EXPECT_LT(worst_bias, 0.001);         // a micrometre: far below the MDF's depth errors
  EXPECT_LT(worst_height_sigma, 0.05);  // the MDF's depth error budget is tenths of a mm
}

// Conditioning of the two-height method on exact lines: the normal's sigma
// grows as the plates come closer (angle error ~ line error / height
// difference), and the height sigma grows without bound as the camera's ray
// runs along the plane.
TEST(LaserPlaneFit, SigmasFollowThePlatesGapAndTheRaysGrazing) {
  auto line = [](double height, double x, double offset_sigma = 0.01, double direction_sigma = 0.0) {
    ReferenceLine l;
    l.valid = true;
    l.height = height;
    l.point = Eigen::Vector2d(x, 0);
    l.direction = Eigen::Vector2d(0, 1);
    l.offset_sigma_mm = offset_sigma;
    l.direction_sigma_rad = direction_sigma;
    return l;
  };
  // A plane at 45 degrees: x = z.
  const Eigen::Vector3d above(0, 0, 500);
  const LaserPlaneFit wide = FitPlaneThroughLines(line(0, 0), line(10, 10), above);
  const LaserPlaneFit narrow = FitPlaneThroughLines(line(0, 0), line(2, 2), above);
  EXPECT_NEAR(AngleToReferencePlane(wide.plane), std::numbers::pi / 4, 1e-12);
  // sigma(angle) = sqrt(2) 0.01 / gap x cos^2(45 deg) from the offsets alone.
  EXPECT_NEAR(wide.normal_sigma_rad, std::sqrt(2.0) * 0.01 / 10 * 0.5, 0.1 * wide.normal_sigma_rad);
  EXPECT_NEAR(narrow.normal_sigma_rad / wide.normal_sigma_rad, 5.0, 0.5);
  // The anchor is between the lines: its position sigma is the offsets'
  // mean across the plane, sqrt(2)/2 x 0.01 x cos(45 deg).
  EXPECT_NEAR(wide.position_sigma_mm, 0.5 * std::sqrt(2.0) * 0.01 * std::sqrt(0.5), 1e-4);
  // Seen from straight above: a height error of position / cos(45 deg).
  EXPECT_NEAR(wide.height_sigma_mm, wide.position_sigma_mm / std::sqrt(0.5), 1e-3);
  // A camera in the plane (x = z, far up it) sees the plane edge-on.
  // Turning both lines turns the plane about the vertical by half their
  // turn each: sqrt(2) x 0.001 / 2, seen on a normal whose horizontal part is cos(45 deg).
  const LaserPlaneFit turned = FitPlaneThroughLines(line(0, 0, 0, 0.001), line(10, 10, 0, 0.001), above);
  EXPECT_NEAR(turned.normal_sigma_rad, std::sqrt(2.0) * 0.0005 * std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(turned.position_sigma_mm, 0.0, 1e-9);  // the anchor stays on the plane
  const LaserPlaneFit grazing = FitPlaneThroughLines(line(0, 0), line(10, 10), Eigen::Vector3d(500, 0, 500.001));
  EXPECT_GT(grazing.height_sigma_mm, 100 * wide.height_sigma_mm);
}

}  // namespace
}  // namespace mesocap::calibration
