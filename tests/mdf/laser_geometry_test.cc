// Laser line detection, the two-height plane calibration, per-frame planes,
// triangulation conditioning and the paper's merge weight, against the
// simulated rig's exact laser planes (sim/camera_renderer.h LaserPlaneAt).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "calibration/laser_plane_calibration.h"
#include "calibration/nominal_geometry.h"
#include "calibration/rig_frames.h"
#include "core/plane.h"
#include "formats/rig_description.h"
#include "formats/sweep_analysis.h"
#include "mdf/displacement_image.h"
#include "mdf/displacement_merge.h"
#include "mdf/frame_plane.h"
#include "mdf/laser_sweep.h"
#include "sim/camera_renderer.h"
#include "sim/camera_sensor.h"
#include "sim/mesostructure_scene.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"

namespace mesocap::mdf {
namespace {

class LaserGeometryTest : public ::testing::Test {
 protected:
  LaserGeometryTest()
      : scene_(sim::MakeBuiltinScene("flat")),
        rig_(sim::LoadRig("small")),
        calibration_(sim::TrueCalibration(rig_)),
        renderer_(*scene_, rig_) {}

  core::Image Sense(const core::Image& signal, int cam, std::uint64_t k) const {
    std::mt19937_64 rng = sim::ImageNoiseGenerator(11, {k});
    return sim::ApplySensor(signal, rig_.cameras[cam], rng, true);
  }

  std::unique_ptr<sim::MesostructureScene> scene_;
  formats::RigDescription rig_;
  formats::Calibration calibration_;
  sim::CameraRenderer renderer_;
};

// Distance (mm) of the true plane's trace on z = height from a detected
// line, at the line's point and 10 mm along it.
double TraceError(const sim::LaserPlane& truth, const calibration::ReferenceLine& line) {
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
  const calibration::CameraRays rays(calibration_.cameras[cam]);
  const core::RigidTransform world_from_sample = calibration::WorldFromSample(calibration_.turntable, 0.0);
  const calibration::PixelMask region = ReferenceRegion(rays, world_from_sample, rig_.sample_size_mm, 1.0, 30.0);
  const sim::CameraView view = renderer_.TraceSample(cam, 0.0);
  for (int li : {0, 4, 6}) {
    const auto& loc = rig_.laser.locations[li];
    const sim::LaserSweepRenderer sweep(renderer_, view, loc.mount, loc.arc_angle_rad);
    const calibration::LaserMountPose pose = calibration::MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, 0.0);
    for (double offset : {-12.0, 0.0, 9.0}) {
      const double tilt = calibration::LaserTiltForOffset(rig_.laser, loc.mount, offset);
      const calibration::ReferenceLine line =
          calibration::DetectLaserLine(Sense(sweep.Frame(tilt), cam, li * 100 + static_cast<int>(offset + 50)), region, rays,
                          0.0, pose.normal.head<2>().normalized(), {});
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
  const calibration::CameraRays rays(calibration_.cameras[cam]);
  const calibration::PixelMask region =
      ReferenceRegion(rays, calibration::WorldFromSample(calibration_.turntable, 0.0), rig_.sample_size_mm, 1.0, 30.0);
  const core::Image dark = Sense(core::Image(rays.width(), rays.height(), 1, 0.0f), cam, 1);
  EXPECT_FALSE(calibration::DetectLaserLine(dark, region, rays, 0.0, {1, 0}, {}).valid);
}

TEST_F(LaserGeometryTest, TwoHeightCalibrationRecoversThePlaneAngle) {
  for (int li : {0, 4, 7}) {  // one per mount (45, 67.5, 84.375 degrees)
    const auto& loc = rig_.laser.locations[li];
    const int cam = 2;
    const calibration::CameraRays rays(calibration_.cameras[cam]);
    core::Image plates[2];
    for (int h = 0; h < 2; ++h) {
      const sim::CameraView plate = renderer_.TracePlate(cam, rig_.laser.calibration_heights_mm[h]);
      plates[h] = Sense(sim::LaserSweepRenderer(renderer_, plate, loc.mount, loc.arc_angle_rad).Frame(0.0), cam,
                        500 + 2 * li + h);
    }
    const calibration::LaserMountPose pose = calibration::MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, 0.0);
    const core::Plane plane = calibration::CalibrateLaserPlane(plates[0], rig_.laser.calibration_heights_mm[0], plates[1],
                                            rig_.laser.calibration_heights_mm[1], rays,
                                            pose.normal.head<2>().normalized(), 30.0, {}, "test");
    const sim::LaserPlane truth = renderer_.LaserPlaneAt(loc.mount, loc.arc_angle_rad, 0.0);
    // Sec. 3.2's angle between laser plane and reference plane.
    const double true_angle = std::acos(std::abs(truth.normal.z()));
    EXPECT_NEAR(calibration::AngleToReferencePlane(plane), true_angle, 0.1 * std::numbers::pi / 180) << "location " << li;
    EXPECT_GT(std::abs(plane.normal.dot(truth.normal)), std::cos(0.1 * std::numbers::pi / 180));
    EXPECT_LT(std::abs(plane.SignedDistance(truth.source)), 2.0);  // 700 mm away, 0.1 degree ~ 1.2 mm
  }
  // A stripe missing from one plate is an error naming the location.
  const calibration::CameraRays rays(calibration_.cameras[0]);
  const core::Image dark(rays.width(), rays.height(), 1, 0.0f);
  EXPECT_THROW(calibration::CalibrateLaserPlane(dark, 0.0, dark, 10.0, rays, {1, 0}, 30.0, {}, "location 0"), core::Error);
}

TEST_F(LaserGeometryTest, FramePlaneFollowsTheTilt) {
  const auto& loc = rig_.laser.locations[3];
  const calibration::LaserMountPose pose = calibration::MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, 0.0);
  const sim::LaserPlane at_zero = renderer_.LaserPlaneAt(loc.mount, loc.arc_angle_rad, 0.0);
  core::Plane calibrated{at_zero.normal, at_zero.normal.dot(at_zero.source)};
  const double tilt = calibration::LaserTiltForOffset(rig_.laser, loc.mount, 12.0);
  const sim::LaserPlane truth = renderer_.LaserPlaneAt(loc.mount, loc.arc_angle_rad, tilt);
  // The exact trace of the tilted plane on z = 0.
  const Eigen::Vector3d along = truth.normal.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d foot = (truth.normal.dot(truth.source) / truth.normal.head<2>().squaredNorm()) *
                               Eigen::Vector3d(truth.normal.x(), truth.normal.y(), 0);
  calibration::ReferenceLine line{true, 0.0, {foot.x(), foot.y()}, {along.x(), along.y()}, 100, 100, 0.0};
  ASSERT_NEAR(truth.normal.dot(Eigen::Vector3d(foot.x(), foot.y(), 0) - truth.source), 0.0, 1e-9);
  const core::Plane plane = FramePlane(line, calibrated, pose.tilt_axis, tilt);
  EXPECT_GT(plane.normal.dot(truth.normal), 1 - 1e-12);
  // The paper's parallel-plane approximation (delta 0) is off by the tilt:
  const core::Plane parallel = FramePlane(line, calibrated, pose.tilt_axis, 0.0);
  EXPECT_NEAR(std::acos(std::min(1.0, parallel.normal.dot(truth.normal))), std::abs(tilt), 1e-6);
  // 2 mm below the reference plane that is ~2 tan(tilt) mm of error.
  const Eigen::Vector3d deep(foot.x(), foot.y(), -2.0);
  EXPECT_LT(std::abs(plane.SignedDistance(deep) - truth.normal.dot(deep - truth.source)), 1e-9);
}

TEST_F(LaserGeometryTest, IllConditionedTriangulationIsRejectedNotWild) {
  // One camera pixel, planes at every frame that nearly contain its ray:
  // the intersection's error grows as 1 / |ray . n|.
  const calibration::CameraRays rays(calibration_.cameras[1]);
  const int x = rays.width() / 2, y = rays.height() / 2;
  const Eigen::Vector3d ray = rays.Ray(x, y);
  formats::SweepAnalysis a;
  a.width = rays.width();
  a.height = rays.height();
  a.frame_count = 2;
  a.peak_time.assign(static_cast<std::size_t>(a.width) * a.height, std::nanf(""));
  a.peak_value.assign(a.peak_time.size(), 0.0f);
  a.peak_time[static_cast<std::size_t>(y) * a.width + x] = 0.5f;
  const Eigen::Vector3d target(0.1, 0.2, -0.5);  // sample point on the ray... nearly
  const Eigen::Vector3d on_ray = rays.centre() + (target - rays.centre()).dot(ray) * ray;
  auto plane_with_sine = [&](double sine) {
    // A normal at angle asin(sine) from the plane containing the ray.
    const Eigen::Vector3d perpendicular = ray.cross(Eigen::Vector3d::UnitZ()).normalized();
    const Eigen::Vector3d n = (std::sqrt(1 - sine * sine) * perpendicular + sine * ray).normalized();
    return core::Plane{n, n.dot(on_ray)};
  };
  const core::RigidTransform identity = calibration::WorldFromSample(calibration_.turntable, 0.0);
  TriangulationOptions options;
  const double limit = options.min_ray_plane_sine;
  for (double sine : {0.5, 0.2, 1.3 * limit}) {
    a.planes = {plane_with_sine(sine), plane_with_sine(sine)};
    const auto points = TriangulateSweep(a, rays, identity, options);
    const Eigen::Vector3f q = points.first[static_cast<std::size_t>(y) * a.width + x];
    ASSERT_TRUE(q.allFinite()) << sine;
    EXPECT_LT((q.cast<double>() - on_ray).norm(), 1e-6);
  }
  for (double sine : {0.7 * limit, 0.001, 0.0}) {
    a.planes = {plane_with_sine(sine), plane_with_sine(sine)};
    const auto points = TriangulateSweep(a, rays, identity, options);
    EXPECT_FALSE(points.first[static_cast<std::size_t>(y) * a.width + x].allFinite()) << sine;
  }
}

TEST(PlaneAtTimeTest, BlendsAndBridgesDroppedFrames) {
  std::vector<core::Plane> planes(6);
  for (int i = 0; i < 6; ++i) planes[i] = core::Plane{Eigen::Vector3d(1, 0, 0), 2.0 * i};
  planes[3] = core::Plane{};  // dropped
  EXPECT_NEAR(PlaneAtTime(planes, 1.25).offset, 2.5, 1e-12);
  EXPECT_NEAR(PlaneAtTime(planes, 2.5).offset, 5.0, 1e-12);  // bridged over frame 3
  EXPECT_NEAR(PlaneAtTime(planes, 3.0).offset, 6.0, 1e-12);
  EXPECT_FALSE(PlaneAtTime(planes, 5.5).valid());
  EXPECT_FALSE(PlaneAtTime(planes, -0.1).valid());
  EXPECT_FALSE(PlaneAtTime(planes, 2.5, 1).valid());  // a gap wider than allowed
}

TEST(ScanWeightTest, TetrahedronVanishesWhenTheCameraIsInTheLaserPlane) {
  const Eigen::Vector3d source(400, 0, 400);
  const core::Plane plane{Eigen::Vector3d(1, 0, 1).normalized(), Eigen::Vector3d(1, 0, 1).normalized().dot(source)};
  // Its trace shifted through the origin is the y axis; a camera in the
  // plane through it and the source (x = z) sees the stripe edge-on.
  EXPECT_NEAR(ScanWeight(source, Eigen::Vector3d(300, 50, 300), plane, 10.0), 0.0, 1e-6);
  const double across = ScanWeight(source, Eigen::Vector3d(0, 0, 400), plane, 10.0);
  // |(s - a) . ((c - a) x (b - a))| / 6 with a, b = (0, -+10, 0): 20 * 400 * 400 / 6.
  EXPECT_NEAR(across, 20.0 * 400 * 400 / 6, 1e-6);
  EXPECT_EQ(ScanWeight(source, Eigen::Vector3d(0, 0, 400), core::Plane{}, 10.0), 0.0);
}

}  // namespace
}  // namespace mesocap::mdf
