// The laser mounts from the stripe on the two-height plates at both ends of
// each sweep (calibration/laser_mount_calibration.h), against the simulated
// small rig's exact mounts. The plates are rendered with the sensor's noise
// and measured through the exact cameras, so the figures are the method's
// own; the fit starts from mounts moved off the truth.
#include "calibration/laser_mount_calibration.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <vector>

#include "calibration/camera_rays.h"
#include "calibration/nominal_geometry.h"
#include "calibration/rig_frames.h"
#include "core/angles.h"
#include "sim/camera_sensor.h"
#include "sim/laser_sweep_renderer.h"
#include "tests/common/flat_small_rig.h"

namespace mesocap::calibration {
namespace {

class LaserMountTest : public testing::FlatSmallRigTest {
 protected:
  // The planes of `locations` at the two tilts that move their stripe
  // offset_mm either side of the sweep's centre, one per camera (all of
  // them, or those given).
  std::vector<LaserPlaneObservation> MeasurePlanes(double offset_mm, const std::vector<int>& locations,
                                                   std::vector<int> cameras = {}) {
    if (cameras.empty()) {
      for (int cam = 0; cam < static_cast<int>(rig_.cameras.size()); ++cam) cameras.push_back(cam);
    }
    std::vector<LaserPlaneObservation> planes;
    for (int cam : cameras) {
      const CameraRays rays(calibration_.cameras[cam]);
      const sim::CameraView plates[2] = {renderer_.TracePlate(cam, rig_.laser.calibration_heights_mm[0]),
                                         renderer_.TracePlate(cam, rig_.laser.calibration_heights_mm[1])};
      for (int li : locations) {
        const formats::LaserLocation& loc = rig_.laser.locations[li];
        for (double offset : {-offset_mm, offset_mm}) {
          const double tilt = LaserTiltForOffset(rig_.laser, loc.mount, offset);
          core::Image frames[2];
          for (int h = 0; h < 2; ++h) {
            std::mt19937_64 rng =
                sim::ImageNoiseGenerator(7, {static_cast<std::uint64_t>(cam), static_cast<std::uint64_t>(li),
                                             static_cast<std::uint64_t>(offset > 0), static_cast<std::uint64_t>(h)});
            frames[h] = sim::ApplySensor(
                sim::LaserSweepRenderer(renderer_, plates[h], loc.mount, loc.arc_angle_rad).Frame(tilt),
                rig_.cameras[cam], rng, true);
          }
          const Eigen::Vector2d scan =
              MountInWorld(calibration_, loc.mount, loc.arc_angle_rad, tilt).normal.head<2>().normalized();
          LaserPlaneObservation plane;
          plane.camera = cam;
          plane.mount = loc.mount;
          plane.arc_rad = loc.arc_angle_rad;
          plane.tilt_rad = tilt;
          plane.name = "location " + std::to_string(li) + " camera " + std::to_string(cam);
          try {
            plane.fit = CalibrateLaserPlane(frames[0], rig_.laser.calibration_heights_mm[0], frames[1],
                                            rig_.laser.calibration_heights_mm[1], rays, scan, 1.5 * rig_.sample_size_mm,
                                            {}, plane.name);
          } catch (const core::Error&) {
            continue;  // this camera does not see the stripe on both plates
          }
          planes.push_back(plane);
        }
      }
    }
    return planes;
  }

  // The true mounts moved: each tilt axis turned by 1 degree, its source
  // moved 3 mm across and along it, its plane turned 0.3 degree about it.
  formats::Calibration MovedStart() const {
    formats::Calibration start = calibration_;
    for (formats::LaserMountCalibration& m : start.laser_mounts) {
      const Eigen::Vector3d across = m.tilt_axis.cross(m.plane_normal_at_zero_tilt).normalized();
      const Eigen::AngleAxisd turn(core::RadiansFromDegrees(1.0), across);
      const Eigen::AngleAxisd about(core::RadiansFromDegrees(0.3), m.tilt_axis);
      m.source_mm += 3.0 * across + 2.0 * m.plane_normal_at_zero_tilt + 3.0 * m.tilt_axis;
      m.tilt_axis = turn * m.tilt_axis;
      m.plane_normal_at_zero_tilt = turn * (about * m.plane_normal_at_zero_tilt);
    }
    return start;
  }
};

// The angle (radians) between two directions.
double Angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.normalized().cross(b.normalized()).norm(), a.normalized().dot(b.normalized()));
}

TEST_F(LaserMountTest, RecoversTheTiltAxesAndPlanesFromAMovedStart) {
  const std::vector<LaserPlaneObservation> planes = MeasurePlanes(13.0, {0, 1, 2, 3, 4, 5, 6, 7});
  ASSERT_GE(planes.size(), 48u);
  const LaserMountResult fit = CalibrateLaserMounts(MovedStart(), planes, {});
  ASSERT_EQ(fit.mounts.size(), calibration_.laser_mounts.size());
  EXPECT_EQ(fit.planes_used + fit.left_out.size(), planes.size());
  for (const SetAsideImage& o : fit.left_out) std::printf("left out %s: %s\n", o.name.c_str(), o.reason.c_str());
  for (std::size_t m = 0; m < fit.mounts.size(); ++m) {
    const formats::LaserMountCalibration& truth = calibration_.laser_mounts[m];
    const formats::LaserMountCalibration& got = fit.mounts[m];
    ASSERT_TRUE(got.uncertainty.tilt_axis && got.uncertainty.source_mm && got.uncertainty.plane_normal_at_zero_tilt);
    const double axis_error = Angle(got.tilt_axis, truth.tilt_axis);
    const double axis_sigma = got.uncertainty.tilt_axis->norm();
    const double normal_error = Angle(got.plane_normal_at_zero_tilt, truth.plane_normal_at_zero_tilt);
    const double normal_sigma = got.uncertainty.plane_normal_at_zero_tilt->norm();
    // The source is observed across its axis only.
    const Eigen::Vector3d d = got.tilt_axis.normalized();
    const Eigen::Vector3d source_error =
        (got.source_mm - truth.source_mm) - (got.source_mm - truth.source_mm).dot(d) * d;
    const double source_sigma = got.uncertainty.source_mm->norm();
    std::printf(
        "mount %zu: axis %.4f deg (sigma %.4f), normal %.5f deg (sigma %.5f), source across the axis %.3f mm "
        "(sigma %.3f)\n",
        m, core::DegreesFromRadians(axis_error), core::DegreesFromRadians(axis_sigma),
        core::DegreesFromRadians(normal_error), core::DegreesFromRadians(normal_sigma), source_error.norm(),
        source_sigma);
    EXPECT_LT(axis_error, 4 * axis_sigma + 1e-6) << "mount " << m;
    EXPECT_LT(normal_error, 4 * normal_sigma + 1e-7) << "mount " << m;
    EXPECT_LT(source_error.norm(), 4 * source_sigma + 1e-3) << "mount " << m;
    // Within the start's move by far, and the plane contains its axis.
    EXPECT_LT(core::DegreesFromRadians(axis_error), 0.2) << "mount " << m;
    EXPECT_LT(core::DegreesFromRadians(normal_error), 0.01) << "mount " << m;
    EXPECT_LT(source_error.norm(), 1.0) << "mount " << m;
    EXPECT_LT(std::abs(got.tilt_axis.normalized().dot(got.plane_normal_at_zero_tilt.normalized())), 1e-9);
  }
  std::printf("residuals: %.5f mm, %.5f deg RMS; too uncertain: \"%s\"\n", fit.position_residual_rms_mm,
              fit.normal_residual_rms_deg, fit.too_uncertain.c_str());
  EXPECT_TRUE(fit.too_uncertain.empty()) << fit.too_uncertain;
}

// Conditioning: planes at tilts closer together meet on a less certain
// line; the axis' sigma grows about as 1 / (tilt difference).
TEST_F(LaserMountTest, CloserTiltsGiveALargerAxisSigma) {
  const std::vector<int> locations = {0, 3, 4, 5, 6, 7};
  const LaserMountResult wide = CalibrateLaserMounts(calibration_, MeasurePlanes(13.0, locations), {});
  const LaserMountResult narrow = CalibrateLaserMounts(calibration_, MeasurePlanes(3.25, locations), {});
  for (std::size_t m = 0; m < wide.mounts.size(); ++m) {
    const double ratio = narrow.mounts[m].uncertainty.tilt_axis->norm() / wide.mounts[m].uncertainty.tilt_axis->norm();
    std::printf("mount %zu: axis sigma x%.2f for a 4x narrower tilt difference\n", m, ratio);
    EXPECT_GT(ratio, 2.0) << "mount " << m;
  }
}

TEST_F(LaserMountTest, AMountSeenAtOneTiltIsAnErrorNamingIt) {
  std::vector<LaserPlaneObservation> planes = MeasurePlanes(13.0, {0, 4, 6}, {1});
  // Keep mount 1's planes at one tilt only.
  std::erase_if(planes, [](const LaserPlaneObservation& p) { return p.mount == 1 && p.tilt_rad > 0; });
  try {
    CalibrateLaserMounts(calibration_, planes, {});
    FAIL() << "expected an error";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("\"mount1\""), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("1 tilt"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mesocap::calibration
