// Laser line detection and the two-height laser-plane calibration (MDF paper
// Sec. 3.2), against the simulated rig's exact laser planes
// (sim/camera_renderer.h LaserPlaneAt).
#include "calibration/laser_plane_calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "calibration/laser_line.h"
#include "calibration/nominal_geometry.h"
#include "calibration/rig_frames.h"
#include "core/plane.h"
#include "formats/rig_description.h"
#include "mdf/laser_sweep.h"
#include "sim/camera_renderer.h"
#include "sim/camera_sensor.h"
#include "tests/common/flat_small_rig.h"

namespace mesocap::calibration {
namespace {

class LaserGeometryTest : public testing::FlatSmallRigTest {
 protected:
  core::Image Sense(const core::Image& signal, int cam, std::uint64_t k) const {
    std::mt19937_64 rng = sim::ImageNoiseGenerator(11, {k});
    return sim::ApplySensor(signal, rig_.cameras[cam], rng, true);
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
    core::Image plates[2];
    for (int h = 0; h < 2; ++h) {
      const sim::CameraView plate = renderer_.TracePlate(cam, rig_.laser.calibration_heights_mm[h]);
      plates[h] = Sense(sim::LaserSweepRenderer(renderer_, plate, loc.mount, loc.arc_angle_rad).Frame(0.0), cam,
                        500 + 2 * li + h);
    }
    const LaserMountPose pose = MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, 0.0);
    const core::Plane plane = CalibrateLaserPlane(plates[0], rig_.laser.calibration_heights_mm[0], plates[1],
                                                  rig_.laser.calibration_heights_mm[1], rays,
                                                  pose.normal.head<2>().normalized(), 30.0, {}, "test");
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

}  // namespace
}  // namespace mesocap::calibration
