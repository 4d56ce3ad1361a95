#include "formats/rig_description.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>

#include "calibration/nominal_geometry.h"
#include "core/error.h"
#include "core/json_field_reader.h"
#include "drivers/device_error.h"
#include "drivers/rig.h"

namespace mesocap::formats {
namespace {

std::filesystem::path RigFile(const std::string& name) {
  return std::filesystem::path(MESOCAP_SOURCE_DIR) / "sim" / "rigs" / (name + ".json");
}

TEST(RigDescription, ShippedRigsHaveThePapersSampling) {
  const RigDescription paper = ReadRigDescription(RigFile("paper"));
  EXPECT_EQ(paper.cameras.size(), 8u);
  EXPECT_EQ(paper.cameras[0].width, 1024);
  EXPECT_EQ(paper.cameras[0].height, 768);
  EXPECT_EQ(paper.lamps.elevations_rad.size(), 8u);
  EXPECT_EQ(paper.view_count(), 12 * 8);
  EXPECT_EQ(paper.light_count(), 12 * 8);
  EXPECT_EQ(paper.laser.locations.size(), 26u);
  const RigDescription tiny = ReadRigDescription(RigFile("tiny"));
  EXPECT_EQ(tiny.cameras[0].width, 128);
  EXPECT_EQ(tiny.cameras[0].height, 96);
  const RigDescription small = ReadRigDescription(RigFile("small"));
  EXPECT_GT(small.view_count(), tiny.view_count());
  EXPECT_LT(small.view_count(), paper.view_count());
}

TEST(RigDescription, DevicePositionsLieAtTheirDistances) {
  const RigDescription rig = ReadRigDescription(RigFile("small"));
  for (const auto& c : rig.cameras) {
    EXPECT_NEAR(calibration::CameraCentre(c).norm(), c.distance_mm, 1e-9);
    EXPECT_NEAR(std::asin(calibration::CameraCentre(c).z() / c.distance_mm), c.elevation_rad, 1e-12);
  }
  EXPECT_NEAR(calibration::LampPosition(rig.lamps, 1, 0.7).norm(), rig.lamps.distance_mm, 1e-9);
  const Eigen::Vector3d lamp = calibration::LampPosition(rig.lamps, 0, 0.7);
  EXPECT_NEAR(std::atan2(lamp.y(), lamp.x()), 0.7, 1e-12);
}

TEST(RigDescription, LaserRaySineIsTheAngleBetweenTheCameraRayAndTheLaserPlane) {
  RigDescription rig = ReadRigDescription(RigFile("small"));
  // The closed form of the header, camera azimuth subtracted from the arc.
  for (int c = 0; c < static_cast<int>(rig.cameras.size()); ++c) {
    for (int l = 0; l < static_cast<int>(rig.laser.locations.size()); ++l) {
      const double ce = rig.cameras[c].elevation_rad;
      const double e = rig.laser.mount_elevations_rad[rig.laser.locations[l].mount];
      const double a = rig.laser.locations[l].arc_angle_rad - rig.cameras[c].azimuth_rad;
      const double expected = std::abs(std::sin(ce) * std::cos(e) - std::cos(ce) * std::sin(e) * std::cos(a));
      EXPECT_NEAR(calibration::LaserRaySine(rig, c, l), expected, 1e-12) << "camera " << c << " location " << l;
      // Cameras up to 60 degrees from the normal: nothing near-coplanar.
      if (ce >= std::numbers::pi / 6) {
        EXPECT_GT(calibration::LaserRaySine(rig, c, l), 0.09) << "camera " << c << " location " << l;
      }
    }
  }
  // A mount at a camera's elevation, at its azimuth: the plane holds the ray.
  rig.laser.mount_elevations_rad.push_back(rig.cameras[1].elevation_rad);
  rig.laser.locations.push_back(
      {static_cast<int>(rig.laser.mount_elevations_rad.size()) - 1, rig.cameras[1].azimuth_rad});
  EXPECT_LT(calibration::LaserRaySine(rig, 1, static_cast<int>(rig.laser.locations.size()) - 1), 1e-12);
}

TEST(RigDescription, LaserTiltMovesTheStripeByTheOffset) {
  const RigDescription rig = ReadRigDescription(RigFile("paper"));
  for (int mount = 0; mount < static_cast<int>(rig.laser.mount_elevations_rad.size()); ++mount) {
    const LaserLocation loc{mount, 0.3};
    const Eigen::Vector3d s = calibration::LaserSource(rig.laser, loc);
    for (double offset : {-20.0, -1.0, 0.0, 5.0, 26.0}) {
      const double tilt = calibration::LaserTiltForOffset(rig.laser, mount, offset);
      // The ray from the source, in the vertical plane, tilted from the
      // direction to the origin, meets z = 0 at the offset beyond the origin.
      const double r = std::hypot(s.x(), s.y());
      const double angle = std::atan2(r, s.z()) + tilt;
      const double reach = s.z() * std::tan(angle);
      EXPECT_NEAR(reach - r, offset, 1e-9) << "mount " << mount;
    }
  }
}

nlohmann::json TinyJson() { return core::ReadJsonFile(RigFile("tiny")); }

std::string ErrorOf(const nlohmann::json& j) {
  try {
    ParseRigDescription(j, "rig.json");
  } catch (const core::FormatError& e) {
    return e.field() + " | " + e.what();
  }
  return "no error";
}

TEST(RigDescription, HostileDescriptionsNameTheField) {
  auto j = TinyJson();
  j["cameras"][1]["id"] = "cam0";
  EXPECT_NE(ErrorOf(j).find("cameras[1].id"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["cameras"][0]["image_size"] = {-128, 96};
  EXPECT_NE(ErrorOf(j).find("cameras[0].image_size"), std::string::npos);
  j = TinyJson();
  j["laser"]["locations"][0]["mount"] = 7;
  EXPECT_NE(ErrorOf(j).find("laser.locations[0].mount"), std::string::npos);
  j = TinyJson();
  j["laser"]["sweep_mm"] = {5, -5};
  EXPECT_NE(ErrorOf(j).find("laser.sweep_mm"), std::string::npos);
  j = TinyJson();
  j["turntable"]["angles_deg"] = nlohmann::json::array();
  EXPECT_NE(ErrorOf(j).find("turntable.angles_deg"), std::string::npos);
  j = TinyJson();
  j["version"] = 2;
  EXPECT_NE(ErrorOf(j).find("version"), std::string::npos);
  j = TinyJson();
  j["cameras"] = nlohmann::json::array();
  EXPECT_NE(ErrorOf(j).find("cameras"), std::string::npos);
  j = TinyJson();
  j["sample"]["backing"]["albedo"] = 1.5;
  EXPECT_NE(ErrorOf(j).find("sample.backing.albedo"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["sample"]["backing"]["depth_mm"] = -2;
  EXPECT_NE(ErrorOf(j).find("sample.backing.depth_mm"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["white_reference"]["albedo"] = 0;
  EXPECT_NE(ErrorOf(j).find("white_reference.albedo"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["white_reference"]["arc_angle_deg"] = 400;
  EXPECT_NE(ErrorOf(j).find("white_reference.arc_angle_deg"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["mirror_sphere"]["radius_mm"] = 0;
  EXPECT_NE(ErrorOf(j).find("mirror_sphere.radius_mm"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["mirror_sphere"].erase("offset_mm");
  EXPECT_NE(ErrorOf(j).find("mirror_sphere.offset_mm': missing"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["mirror_sphere"]["exposure_us"] = 0.5;
  EXPECT_NE(ErrorOf(j).find("mirror_sphere.exposure_us"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["lamps"]["emitter_radius_mm"] = -1;
  EXPECT_NE(ErrorOf(j).find("lamps.emitter_radius_mm"), std::string::npos) << ErrorOf(j);
}

// The mirror sphere's arc angles default to the light arc's.
TEST(RigDescription, TheMirrorSpheresArcAnglesDefaultToTheLightArcs) {
  auto j = TinyJson();
  j["mirror_sphere"].erase("arc_angles_deg");
  RigDescription rig = ParseRigDescription(j, "tiny.json");
  ASSERT_TRUE(rig.mirror_sphere.has_value());
  EXPECT_EQ(rig.mirror_sphere->arc_angles_rad, rig.light_arc.angles_rad);
  j["mirror_sphere"]["arc_angles_deg"] = {90.0};
  rig = ParseRigDescription(j, "tiny.json");
  ASSERT_EQ(rig.mirror_sphere->arc_angles_rad.size(), 1u);
  EXPECT_NEAR(rig.mirror_sphere->arc_angles_rad[0], std::numbers::pi / 2, 1e-12);
}

// The tiny rig with every device on a real backend.
nlohmann::json RealTinyJson() {
  auto j = TinyJson();
  j["cameras"][0]["backend"] = "aravis";
  j["cameras"][0]["device"] = "Basler-a2A1920-40241234";
  j["turntable"].update({{"backend", "tic"},
                         {"serial", "00123456"},
                         {"microsteps", 16},
                         {"gear_ratio", 90},
                         {"homing", "forward"},
                         {"product", "36v4"}});
  nlohmann::json lines = nlohmann::json::array();
  for (std::size_t i = 0; i < j["lamps"]["elevations_deg"].size(); ++i) {
    lines.push_back({{"chip", "gpiochip0"}, {"line", static_cast<int>(i) + 4}});
  }
  j["lamps"].update({{"backend", "gpiod"}, {"lines", lines}, {"settle_ms", 300}});
  j["laser"].update({{"backend", "gpiod"},
                     {"enable", {{"chip", "gpiochip0"}, {"line", "LASER_EN"}, {"active_low", true}}},
                     {"tilt",
                      {{"backend", "gpiod"},
                       {"step", {{"chip", "gpiochip0"}, {"line", 20}}},
                       {"direction", {{"chip", "gpiochip0"}, {"line", 21}}},
                       {"limit_switch", {{"chip", "gpiochip1"}, {"line", "TILT_HOME"}}},
                       {"gear_ratio", 50}}}});
  return j;
}

TEST(RigDescription, RealBackendsNameTheirDevices) {
  const RigDescription rig = ParseRigDescription(RealTinyJson(), "rig.json");
  EXPECT_EQ(rig.cameras[0].device, "Basler-a2A1920-40241234");
  EXPECT_EQ(rig.cameras[1].backend, "sim");  // a rig may mix backends
  EXPECT_EQ(rig.turntable.tic.serial, "00123456");
  EXPECT_EQ(rig.turntable.tic.microsteps, 16);
  EXPECT_EQ(rig.turntable.tic.gear_ratio, 90.0);
  EXPECT_TRUE(rig.turntable.tic.home_forward);
  EXPECT_EQ(rig.turntable.tic.product, "36v4");
  EXPECT_EQ(rig.lamps.lines.size(), rig.lamps.elevations_rad.size());
  EXPECT_EQ(rig.lamps.lines[1].offset, 5);
  EXPECT_EQ(rig.lamps.settle_ms, 300.0);
  EXPECT_EQ(rig.laser.enable.name, "LASER_EN");
  EXPECT_TRUE(rig.laser.enable.active_low);
  EXPECT_EQ(rig.laser.tilt_backend, "gpiod");
  EXPECT_EQ(rig.laser.tilt_stepper.limit_switch.chip, "gpiochip1");
  EXPECT_EQ(rig.laser.tilt_stepper.gear_ratio, 50.0);
}

TEST(RigDescription, RealBackendFieldsAreValidatedByName) {
  const std::vector<std::pair<std::function<void(nlohmann::json&)>, std::string>> cases = {
      {[](auto& j) { j["cameras"][0].erase("device"); }, "cameras[0].device"},
      {[](auto& j) { j["cameras"][1]["device"] = "127.0.0.2"; }, "cameras[1].device"},
      {[](auto& j) { j["cameras"][0]["backend"] = "usb"; }, "cameras[0].backend"},
      {[](auto& j) { j["turntable"].erase("serial"); }, "turntable.serial"},
      {[](auto& j) { j["turntable"]["microsteps"] = 3; }, "turntable.microsteps"},
      {[](auto& j) { j["turntable"]["product"] = "T999"; }, "turntable.product"},
      {[](auto& j) { j["light_arc"]["serial"] = "1"; }, "light_arc.serial"},  // a "sim" stage has none
      {[](auto& j) { j["lamps"]["lines"].erase(0); }, "lamps.lines"},
      {[](auto& j) { j["lamps"]["lines"][0]["line"] = -1; }, "lamps.lines[0].line"},
      {[](auto& j) { j["lamps"]["lines"][0]["chip"] = ""; }, "lamps.lines[0].chip"},
      {[](auto& j) { j["laser"]["tilt"]["backend"] = "servo"; }, "laser.tilt.backend"},
      {[](auto& j) { j["laser"]["tilt"].erase("step"); }, "laser.tilt.step"},
      {[](auto& j) { j["laser"].erase("enable"); }, "laser.enable"},
  };
  for (const auto& [edit, field] : cases) {
    auto j = RealTinyJson();
    edit(j);
    EXPECT_EQ(ErrorOf(j).substr(0, ErrorOf(j).find(" | ")), field) << ErrorOf(j);
  }
}

// A misspelt member is an error at every level, never a silent default.
TEST(RigDescription, UnknownMembersAreErrorsAtEveryLevel) {
  const std::vector<std::pair<nlohmann::json::json_pointer, std::string>> misspelt = {
      {nlohmann::json::json_pointer("/nmae"), "nmae"},
      {nlohmann::json::json_pointer("/sample/size"), "sample.size"},
      {nlohmann::json::json_pointer("/sample/backing/albdeo"), "sample.backing.albdeo"},
      {nlohmann::json::json_pointer("/cameras/0/bit_depht"), "cameras[0].bit_depht"},
      {nlohmann::json::json_pointer("/turntable/speed"), "turntable.speed"},
      {nlohmann::json::json_pointer("/light_arc/angles"), "light_arc.angles"},
      {nlohmann::json::json_pointer("/lamps/intensities"), "lamps.intensities"},
      {nlohmann::json::json_pointer("/laser/sweep_storge"), "laser.sweep_storge"},
      {nlohmann::json::json_pointer("/laser/locations/0/arc_deg"), "laser.locations[0].arc_deg"},
      {nlohmann::json::json_pointer("/calibration_board/hieght_mm"), "calibration_board.hieght_mm"},
      {nlohmann::json::json_pointer("/white_reference/albdeo"), "white_reference.albdeo"},
  };
  for (const auto& [pointer, field] : misspelt) {
    auto j = TinyJson();
    j[pointer] = 8;
    EXPECT_EQ(ErrorOf(j).substr(0, ErrorOf(j).find(" | ")), field);
    EXPECT_NE(ErrorOf(j).find("unknown member"), std::string::npos) << ErrorOf(j);
  }
  auto j = TinyJson();
  j["laser"]["sweep_storge"] = "analysis";
  EXPECT_EQ(ErrorOf(j),
            "laser.sweep_storge | rig.json: field 'laser.sweep_storge': unknown member; expected only "
            "backend, distance_mm, mount_elevations_deg, locations, sweep_mm, frames_per_sweep, "
            "stripe_sigma_mm, power, calibration_heights_mm, sweep_storage");
}

// Numbers without a range before (lamp intensity, principal point,
// calibration heights) now have one, and the message states it.
TEST(RigDescription, EveryNumberHasARangeInTheMessage) {
  auto j = TinyJson();
  j["lamps"]["intensity"] = {1, 1e300, 1};
  EXPECT_NE(
      ErrorOf(j).find("lamps.intensity | rig.json: field 'lamps.intensity': expected three numbers in [0, 1e+12]"),
      std::string::npos)
      << ErrorOf(j);
  j = TinyJson();
  j["cameras"][0]["principal_point_px"] = {1e300, 0};
  EXPECT_NE(ErrorOf(j).find("[-1e+06, 1e+06] pixels"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["laser"]["calibration_heights_mm"] = {0, 1e300};
  EXPECT_NE(ErrorOf(j).find("in [0, 10000] mm"), std::string::npos) << ErrorOf(j);
  j = TinyJson();
  j["turntable"]["angles_deg"] = {0, 400};
  EXPECT_NE(ErrorOf(j).find("field 'turntable.angles_deg[1]': expected an angle in [0, 360] degrees, got 400"),
            std::string::npos)
      << ErrorOf(j);
}

// A 3 MB value or member name is echoed cut to 200 characters.
TEST(RigDescription, HugeStringsAreCutInTheMessage) {
  const std::string huge(3 << 20, 'x');
  const auto message = [](const nlohmann::json& rig) {
    try {
      ParseRigDescription(rig, "rig.json");
    } catch (const core::FormatError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  auto j = TinyJson();
  j["laser"]["sweep_storage"] = huge;
  std::string error = message(j);
  EXPECT_LT(error.size(), 600u);
  EXPECT_NE(error.find("got \"" + std::string(200, 'x') + "... (3145728 bytes in all)\""), std::string::npos) << error;
  j = TinyJson();
  j["cameras"][0][huge] = 1;
  error = message(j);
  EXPECT_LT(error.size(), 400u);
  EXPECT_NE(error.find("field 'cameras[0]." + std::string(60, 'x') + "... (3145728 bytes in all)'"), std::string::npos)
      << error.substr(0, 400);
}

TEST(RigDescription, BackingIsOptional) {
  // The shipped rigs hold their samples over a grey board 8 mm down.
  for (const char* name : {"tiny", "small", "paper"}) {
    const RigDescription rig = ReadRigDescription(RigFile(name));
    EXPECT_TRUE(rig.backing.present()) << name;
    EXPECT_DOUBLE_EQ(rig.backing.depth_mm, 8.0) << name;
  }
  auto j = TinyJson();
  j["sample"].erase("backing");
  EXPECT_FALSE(ParseRigDescription(j, "rig.json").backing.present());
}

TEST(Rig, MissingBackendIsNamed) {
  const RigDescription rig = ReadRigDescription(RigFile("tiny"));
  try {
    drivers::BuildRig(rig, {});
    FAIL();
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera cam0: backend \"sim\" is not available"), std::string::npos)
        << e.what();
  }
  // A backend that makes nothing says what it cannot drive.
  struct Empty : drivers::RigBackend {
    std::string name() const override { return "empty"; }
  } empty;
  EXPECT_THROW(drivers::BuildRig(rig, {{"sim", &empty}}), drivers::DeviceError);
}

}  // namespace
}  // namespace mesocap::formats
