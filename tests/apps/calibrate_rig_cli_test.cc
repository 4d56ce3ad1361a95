// `mesocap simulate --plan calibration` then `mesocap calibrate --session` on
// a shipped rig (MESOCAP_CALIBRATION_RIG: the small rig as an accuracy test,
// the tiny one everywhere, the sanitizers included), against the simulated
// rig's exact calibration: the sample area's image, the cameras' focal
// lengths and centres within their reported uncertainty, honest
// cross-validation, the light arc and lamps from the mirror sphere, the
// laser mounts from the plates, and the gains and lamp intensities from the
// white reference. The tiny rig's 128 x 96 cameras see the board's corners
// less sharply and its focal lengths only to a few percent, hence its own
// bounds on the reported figures; the truth must lie within the same number
// of sigmas on both.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "calibration/camera_calibration.h"
#include "formats/calibration.h"
#include "tests/common/mesocap_command.h"

namespace mesocap {
namespace {

using testing::Mesocap;
using testing::TemporaryDirectory;

// What the rig's calibration must reach, as the report gives it.
struct ReportBounds {
  double rms_px;               // per camera
  double projection_sigma_px;  // the sample centre's, one sigma
  double cross_validation_px;
  double sample_mm;  // the sample square's side (its rig description)
};

ReportBounds BoundsFor(const std::string& rig) {
  if (rig == "small") return {0.2, 0.1, 0.1, 20.0};
  return {0.25, 0.15, 0.3, 12.0};
}

class CalibrateRigCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    folder_ = new TemporaryDirectory;
    const auto r = Mesocap(std::string("simulate --plan calibration --rig ") + MESOCAP_CALIBRATION_RIG +
                           " --scene weave --out " + Session().string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
  }
  static void TearDownTestSuite() { delete folder_; }
  static std::filesystem::path Session() { return *folder_ / "calibration-session"; }
  static TemporaryDirectory* folder_;
};
TemporaryDirectory* CalibrateRigCli::folder_ = nullptr;

void ExpectCamerasWithinTheirUncertainty(const nlohmann::json& report, const formats::Calibration& truth,
                                         const formats::Calibration& estimate, const ReportBounds& bounds) {
  for (std::size_t c = 0; c < truth.cameras.size(); ++c) {
    const formats::CameraCalibration& t = truth.cameras[c];
    const formats::CameraCalibration& e = estimate.cameras[c];
    const nlohmann::json& row = report["cameras"][c];
    EXPECT_LT(row["rms_px"].get<double>(), bounds.rms_px) << e.id;
    EXPECT_NEAR(e.intrinsics.fx, t.intrinsics.fx, 4 * *e.intrinsics.uncertainty.fx) << e.id;
    for (int axis = 0; axis < 3; ++axis) {
      EXPECT_NEAR(e.pose.transform.translation[axis], t.pose.transform.translation[axis],
                  4 * (*e.pose.uncertainty.translation_mm)[axis] + 1e-3)
          << e.id << " centre axis " << axis;
    }
    // Where the sample's points land in the image: what processing uses.
    const double sigma = row["projection_uncertainty_px"].get<double>();
    EXPECT_LT(sigma, bounds.projection_sigma_px) << e.id;
    const double half = 0.5 * bounds.sample_mm;
    for (const Eigen::Vector3d& point : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.8 * half, -0.8 * half, 0),
                                         Eigen::Vector3d(-0.8 * half, 0.5 * half, 0)}) {
      const auto image = [&](const formats::CameraCalibration& cam) {
        return calibration::ProjectInCamera(
            cam, cam.pose.transform.rotation.transpose() * (point - cam.pose.transform.translation));
      };
      EXPECT_LT((image(e) - image(t)).norm(), 5 * sigma + 0.01) << e.id << " at " << point.transpose();
    }
    EXPECT_LT(row["cross_validation_px"].get<double>(), bounds.cross_validation_px) << e.id;
  }
}

void ExpectTheLightArcAndLamps(const nlohmann::json& report, const formats::Calibration& truth,
                               const formats::Calibration& estimate) {
  // The light arc and lamps from the mirror sphere: on the small rig within
  // 4 sigma and 3 mm of the truth (the estimated cameras' errors dominate,
  // and the sigmas carry them); the tiny rig's cameras resolve the sphere too
  // coarsely, so its fit is reported and the description's lamps are kept.
  const nlohmann::json& arc = report["light_arc"];
  ASSERT_TRUE(arc.is_object()) << report.dump();
  EXPECT_GT(arc["highlights_used"].get<int>(), 0);
  if (std::string(MESOCAP_CALIBRATION_RIG) == "small") {
    EXPECT_TRUE(arc["written"].get<bool>()) << arc["too_uncertain"];
    EXPECT_EQ(report["nominal_parts"].get<std::string>().find("lamp positions"), std::string::npos);
    EXPECT_LT(std::acos(std::min(1.0, estimate.light_arc.axis_direction.dot(truth.light_arc.axis_direction))),
              0.05 * std::numbers::pi / 180);
    for (std::size_t l = 0; l < truth.lamps.size(); ++l) {
      ASSERT_TRUE(estimate.lamps[l].uncertainty.position_mm.has_value()) << truth.lamps[l].id;
      const Eigen::Vector3d error = estimate.lamps[l].position_mm - truth.lamps[l].position_mm;
      EXPECT_LT(error.norm(), 3.0) << truth.lamps[l].id;
      for (int axis = 0; axis < 3; ++axis) {
        EXPECT_LT(std::abs(error[axis]), 4 * (*estimate.lamps[l].uncertainty.position_mm)[axis])
            << truth.lamps[l].id << " axis " << axis;
      }
    }
  } else {
    EXPECT_FALSE(arc["written"].get<bool>());
    EXPECT_NE(arc["too_uncertain"].get<std::string>().find("position is uncertain to"), std::string::npos);
    EXPECT_NE(report["nominal_parts"].get<std::string>().find("lamp positions"), std::string::npos);
    for (std::size_t l = 0; l < truth.lamps.size(); ++l) {
      EXPECT_EQ(estimate.lamps[l].position_mm, truth.lamps[l].position_mm) << truth.lamps[l].id;
    }
  }
}

void ExpectTheLaserMounts(const nlohmann::json& report, const formats::Calibration& truth,
                          const formats::Calibration& estimate) {
  // The laser mounts from the plates at both ends of each sweep. Small rig:
  // each tilt axis within 0.5 degree and 4 of its sigmas (what processing
  // uses, turning a plate's plane by the sweep's tilt); each source within
  // 12 mm across its axis. The sources' sigmas leave out the error the
  // cameras share (all estimated 0.6 to 1.2 mm short along their views),
  // which turns every plate plane alike: the source's bound is in mm, not
  // sigmas. Tiny rig: too uncertain, the description's mounts kept.
  const nlohmann::json& laser = report["laser_mount_fit"];
  ASSERT_TRUE(laser.is_object()) << report.dump();
  ASSERT_EQ(report["laser_mounts"].size(), truth.laser_mounts.size());
  ASSERT_EQ(estimate.laser_mounts.size(), truth.laser_mounts.size());
  if (std::string(MESOCAP_CALIBRATION_RIG) == "small") {
    EXPECT_TRUE(laser["written"].get<bool>()) << laser["too_uncertain"];
    EXPECT_GT(laser["planes_used"].get<int>(), 32);
    EXPECT_EQ(report["nominal_parts"].get<std::string>().find("laser_mounts"), std::string::npos);
    for (std::size_t m = 0; m < truth.laser_mounts.size(); ++m) {
      const formats::LaserMountCalibration& t = truth.laser_mounts[m];
      const formats::LaserMountCalibration& e = estimate.laser_mounts[m];
      ASSERT_TRUE(e.uncertainty.tilt_axis.has_value()) << t.id;
      const Eigen::Vector3d axis = e.tilt_axis.normalized();
      EXPECT_LT(std::acos(std::min(1.0, axis.dot(t.tilt_axis.normalized()))), 0.5 * std::numbers::pi / 180) << t.id;
      for (int k = 0; k < 3; ++k) {
        EXPECT_LT(std::abs(axis[k] - t.tilt_axis.normalized()[k]), 4 * (*e.uncertainty.tilt_axis)[k] + 1e-6)
            << t.id << " axis component " << k;
      }
      const Eigen::Vector3d source = e.source_mm - t.source_mm;
      EXPECT_LT((source - source.dot(axis) * axis).norm(), 12.0) << t.id;
      EXPECT_LT(std::abs(axis.dot(e.plane_normal_at_zero_tilt.normalized())), 1e-6) << t.id;
    }
  } else {
    EXPECT_FALSE(laser["written"].get<bool>());
    EXPECT_NE(report["nominal_parts"].get<std::string>().find("laser_mounts"), std::string::npos);
    for (std::size_t m = 0; m < truth.laser_mounts.size(); ++m) {
      EXPECT_EQ(estimate.laser_mounts[m].tilt_axis, truth.laser_mounts[m].tilt_axis) << truth.laser_mounts[m].id;
      EXPECT_EQ(estimate.laser_mounts[m].source_mm, truth.laser_mounts[m].source_mm) << truth.laser_mounts[m].id;
    }
  }
}

void ExpectTheGainsAndIntensities(const nlohmann::json& report, const formats::Calibration& truth,
                                  const formats::Calibration& estimate) {
  // Gains and intensities from the white reference: within 1 % of the truth
  // and within 4 of their sigmas.
  for (std::size_t c = 0; c < truth.cameras.size(); ++c) {
    ASSERT_TRUE(estimate.cameras[c].radiometry.has_value()) << estimate.cameras[c].id;
    const formats::CameraRadiometry& e = *estimate.cameras[c].radiometry;
    const double t = truth.cameras[c].radiometry->signal_per_radiance_second;
    EXPECT_NEAR(e.signal_per_radiance_second, t, 0.01 * t) << estimate.cameras[c].id;
    EXPECT_NEAR(e.signal_per_radiance_second, t, 4 * *e.uncertainty.signal_per_radiance_second)
        << estimate.cameras[c].id;
    EXPECT_EQ(report["cameras"][c]["gain"].get<double>(), e.signal_per_radiance_second);
  }
  ASSERT_EQ(estimate.lamps.size(), truth.lamps.size());
  ASSERT_EQ(report["lamps"].size(), truth.lamps.size());
  for (std::size_t l = 0; l < truth.lamps.size(); ++l) {
    for (int ch = 0; ch < 3; ++ch) {
      EXPECT_NEAR(estimate.lamps[l].intensity[ch], truth.lamps[l].intensity[ch], 0.01) << truth.lamps[l].id;
      EXPECT_NEAR(estimate.lamps[l].intensity[ch], truth.lamps[l].intensity[ch],
                  4 * (*estimate.lamps[l].uncertainty.intensity)[ch])
          << truth.lamps[l].id;
    }
  }
}

TEST_F(CalibrateRigCli, CamerasAndTurntableWithinTheirUncertainty) {
  TemporaryDirectory out;
  const auto r =
      Mesocap("calibrate --session " + Session().string() + " --out " + (out / "c.json").string() + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json report = nlohmann::json::parse(r.out);
  // The session records the rig's true calibration (the simulator's), which
  // the calibration never reads.
  const formats::Calibration truth = formats::ReadCalibration(Session() / "calibration.json");
  const formats::Calibration estimate = formats::ReadCalibration(out / "c.json");
  ASSERT_EQ(estimate.cameras.size(), truth.cameras.size());
  const ReportBounds bounds = BoundsFor(MESOCAP_CALIBRATION_RIG);
  ExpectCamerasWithinTheirUncertainty(report, truth, estimate, bounds);
  EXPECT_EQ(report["turntable"]["holders"].size(), 5u);
  ExpectTheLightArcAndLamps(report, truth, estimate);
  ExpectTheLaserMounts(report, truth, estimate);
  ExpectTheGainsAndIntensities(report, truth, estimate);
}

}  // namespace
}  // namespace mesocap
