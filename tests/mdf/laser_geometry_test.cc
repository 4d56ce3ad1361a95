// Per-frame laser planes, triangulation conditioning and the paper's merge
// weight, against the simulated rig's exact laser planes
// (sim/camera_renderer.h LaserPlaneAt). The laser line and the two-height
// plane calibration are tested in tests/calibration/.
#include <gtest/gtest.h>

#include <cmath>

#include "calibration/laser_line.h"
#include "calibration/nominal_geometry.h"
#include "calibration/rig_frames.h"
#include "core/plane.h"
#include "formats/rig_description.h"
#include "formats/sweep_analysis.h"
#include "mdf/displacement_image.h"
#include "mdf/displacement_merge.h"
#include "mdf/frame_plane.h"
#include "sim/camera_renderer.h"
#include "tests/common/flat_small_rig.h"

namespace mesocap::mdf {
namespace {

using LaserGeometryTest = testing::FlatSmallRigTest;

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
