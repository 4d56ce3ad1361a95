#include "formats/calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <random>

#include "core/error.h"
#include "core/json_field_reader.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::formats {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kPi = 3.14159265358979323846;

std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void Spit(const fs::path& p, const std::string& text) { std::ofstream(p, std::ios::binary | std::ios::trunc) << text; }

int CountEntries(const fs::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

core::RigidTransform Pose(const std::string& parent, const std::string& child, double angle,
                          const Eigen::Vector3d& axis, const Eigen::Vector3d& t) {
  core::RigidTransform p;
  p.parent_frame = parent;
  p.child_frame = child;
  p.rotation = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  p.translation = t;
  return p;
}

// A rig like the paper's: cameras on an arc, two lamps, two laser mounts;
// uncertainties on some parameters and not on others.
Calibration ExampleCalibration() {
  Calibration c;
  for (int i = 0; i < 3; ++i) {
    CameraCalibration cam;
    cam.id = "cam" + std::to_string(i);
    cam.width = 1024;
    cam.height = 768;
    cam.intrinsics = {1500.25 + i, 1499.75, 511.5, 383.25, {}};
    cam.distortion = {-0.12, 0.031, 1e-4, -2e-4, 0.005, {}};
    const double elevation = 0.3 * i;
    cam.pose.transform = Pose("world", "camera:" + cam.id, 2.0 + elevation, {1, 0.2, 0.1},
                              {0, -800 * std::cos(elevation), 800 * std::sin(elevation)});
    c.cameras.push_back(cam);
  }
  c.cameras[0].intrinsics.uncertainty.fx = 0.4;
  c.cameras[0].intrinsics.uncertainty.cy = 0.25;
  c.cameras[1].distortion.uncertainty = {1e-3, 2e-3, 1e-5, 1e-5, 0.01};
  c.cameras[2].pose.uncertainty.rotation_rad = Eigen::Vector3d(1e-4, 2e-4, 3e-4);
  c.cameras[2].pose.uncertainty.translation_mm = Eigen::Vector3d(0.1, 0.2, 0.05);
  // Radiometry with an uncertainty, without one, and none (cameras[2]).
  c.cameras[0].radiometry = CameraRadiometry{.signal_per_radiance_second = 1.6e7, .uncertainty = {2.5e4}};
  c.cameras[1].radiometry = CameraRadiometry{.signal_per_radiance_second = 0.75, .uncertainty = {}};

  c.turntable.axis_point_mm = {1.5, -2.25, -40};
  c.turntable.axis_direction = Eigen::Vector3d(0.01, -0.02, 1).normalized();
  c.turntable.sample_pose.transform = Pose("turntable", "sample", 0.1, {0, 0, 1}, {0, 0, 12.5});
  c.turntable.sample_pose.uncertainty.translation_mm = Eigen::Vector3d(0.02, 0.02, 0.01);
  c.turntable.uncertainty.axis_direction = Eigen::Vector3d(1e-4, 1e-4, 0);

  c.light_arc.axis_point_mm = {0, 0, -40};
  c.light_arc.axis_direction = {0, 0, 1};
  c.light_arc.uncertainty.axis_point_mm = Eigen::Vector3d(0.5, 0.5, 0.5);

  LampCalibration lamp;
  lamp.id = "halogen0";
  lamp.position_mm = {600, 0, 300};
  lamp.intensity = {1.0, 0.9, 0.7};
  lamp.uncertainty.intensity = Eigen::Vector3d(0.01, 0.01, 0.02);
  c.lamps.push_back(lamp);
  lamp.id = "halogen1";
  lamp.position_mm = {500, 0, 450};
  lamp.uncertainty = {};
  c.lamps.push_back(lamp);

  LaserMountCalibration m;
  m.id = "mount0";
  m.source_mm = {700, 0, 500};
  m.plane_normal_at_zero_tilt = Eigen::Vector3d(0, 1, 0);
  m.tilt_axis = Eigen::Vector3d(1, 0, -1).normalized();
  m.tilt_range_rad = {-0.35, 0.35};
  m.uncertainty.tilt_range_rad = Eigen::Vector2d(0.001, 0.002);
  m.uncertainty.source_mm = Eigen::Vector3d(1, 1, 1);
  c.laser_mounts.push_back(m);
  m.id = "mount1";
  m.source_mm = {650, 10, 550};
  m.uncertainty = {};
  c.laser_mounts.push_back(m);
  return c;
}

// ---- comparing ------------------------------------------------------------

// Angles pass through degrees in the file, so allow for the last bits.
template <typename V>
void ExpectNear(const V& a, const V& b, const std::string& what) {
  EXPECT_LE((a - b).norm(), 1e-12 * (1 + a.norm())) << what << ": " << a.transpose() << " vs " << b.transpose();
}

template <typename T>
void ExpectNear(const std::optional<T>& a, const std::optional<T>& b, const std::string& what) {
  ASSERT_EQ(a.has_value(), b.has_value()) << what;
  if (a) ExpectNear(*a, *b, what);
}

void ExpectSamePose(const CalibratedPose& a, const CalibratedPose& b, const std::string& what) {
  EXPECT_EQ(a.transform.parent_frame, b.transform.parent_frame) << what;
  EXPECT_EQ(a.transform.child_frame, b.transform.child_frame) << what;
  EXPECT_EQ(a.transform.rotation, b.transform.rotation) << what;
  EXPECT_EQ(a.transform.translation, b.transform.translation) << what;
  ExpectNear(a.uncertainty.rotation_rad, b.uncertainty.rotation_rad, what + ".std.rotation");
  ExpectNear(a.uncertainty.translation_mm, b.uncertainty.translation_mm, what + ".std.translation");
}

void ExpectSame(const Calibration& a, const Calibration& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (std::size_t i = 0; i < a.cameras.size(); ++i) {
    const auto &x = a.cameras[i], &y = b.cameras[i];
    const std::string at = "cameras[" + std::to_string(i) + "]";
    EXPECT_EQ(x.id, y.id);
    EXPECT_EQ(x.width, y.width);
    EXPECT_EQ(x.height, y.height);
    EXPECT_EQ(x.intrinsics.fx, y.intrinsics.fx);
    EXPECT_EQ(x.intrinsics.fy, y.intrinsics.fy);
    EXPECT_EQ(x.intrinsics.cx, y.intrinsics.cx);
    EXPECT_EQ(x.intrinsics.cy, y.intrinsics.cy);
    EXPECT_EQ(x.intrinsics.uncertainty.fx, y.intrinsics.uncertainty.fx);
    EXPECT_EQ(x.intrinsics.uncertainty.fy, y.intrinsics.uncertainty.fy);
    EXPECT_EQ(x.intrinsics.uncertainty.cx, y.intrinsics.uncertainty.cx);
    EXPECT_EQ(x.intrinsics.uncertainty.cy, y.intrinsics.uncertainty.cy);
    EXPECT_EQ(x.distortion.k1, y.distortion.k1);
    EXPECT_EQ(x.distortion.k2, y.distortion.k2);
    EXPECT_EQ(x.distortion.p1, y.distortion.p1);
    EXPECT_EQ(x.distortion.p2, y.distortion.p2);
    EXPECT_EQ(x.distortion.k3, y.distortion.k3);
    EXPECT_EQ(x.distortion.uncertainty.k1, y.distortion.uncertainty.k1);
    EXPECT_EQ(x.distortion.uncertainty.k2, y.distortion.uncertainty.k2);
    EXPECT_EQ(x.distortion.uncertainty.p1, y.distortion.uncertainty.p1);
    EXPECT_EQ(x.distortion.uncertainty.p2, y.distortion.uncertainty.p2);
    EXPECT_EQ(x.distortion.uncertainty.k3, y.distortion.uncertainty.k3);
    ExpectSamePose(x.pose, y.pose, at + ".pose");
    ASSERT_EQ(x.radiometry.has_value(), y.radiometry.has_value()) << at;
    if (x.radiometry) {
      EXPECT_EQ(x.radiometry->signal_per_radiance_second, y.radiometry->signal_per_radiance_second) << at;
      EXPECT_EQ(x.radiometry->uncertainty.signal_per_radiance_second,
                y.radiometry->uncertainty.signal_per_radiance_second)
          << at;
    }
  }
  const auto &t = a.turntable, &u = b.turntable;
  ExpectNear(t.axis_point_mm, u.axis_point_mm, "turntable.axis_point_mm");
  ExpectNear(t.axis_direction, u.axis_direction, "turntable.axis_direction");
  ExpectSamePose(t.sample_pose, u.sample_pose, "turntable.sample_pose");
  ExpectNear(t.uncertainty.axis_point_mm, u.uncertainty.axis_point_mm, "turntable.std.point");
  ExpectNear(t.uncertainty.axis_direction, u.uncertainty.axis_direction, "turntable.std.dir");
  ExpectNear(a.light_arc.axis_point_mm, b.light_arc.axis_point_mm, "light_arc.axis_point_mm");
  ExpectNear(a.light_arc.axis_direction, b.light_arc.axis_direction, "light_arc.axis_direction");
  ExpectNear(a.light_arc.uncertainty.axis_point_mm, b.light_arc.uncertainty.axis_point_mm, "light_arc.std.point");
  ExpectNear(a.light_arc.uncertainty.axis_direction, b.light_arc.uncertainty.axis_direction, "light_arc.std.dir");
  ASSERT_EQ(a.lamps.size(), b.lamps.size());
  for (std::size_t i = 0; i < a.lamps.size(); ++i) {
    const auto &x = a.lamps[i], &y = b.lamps[i];
    EXPECT_EQ(x.id, y.id);
    EXPECT_EQ(x.position_mm, y.position_mm);
    EXPECT_EQ(x.intensity, y.intensity);
    ExpectNear(x.uncertainty.position_mm, y.uncertainty.position_mm, "lamp std position");
    ExpectNear(x.uncertainty.intensity, y.uncertainty.intensity, "lamp std intensity");
  }
  ASSERT_EQ(a.laser_mounts.size(), b.laser_mounts.size());
  for (std::size_t i = 0; i < a.laser_mounts.size(); ++i) {
    const auto &x = a.laser_mounts[i], &y = b.laser_mounts[i];
    EXPECT_EQ(x.id, y.id);
    EXPECT_EQ(x.source_mm, y.source_mm);
    ExpectNear(x.plane_normal_at_zero_tilt, y.plane_normal_at_zero_tilt, "laser normal");
    ExpectNear(x.tilt_axis, y.tilt_axis, "laser tilt axis");
    ExpectNear(x.tilt_range_rad, y.tilt_range_rad, "laser tilt range");
    ExpectNear(x.uncertainty.source_mm, y.uncertainty.source_mm, "laser std source");
    ExpectNear(x.uncertainty.plane_normal_at_zero_tilt, y.uncertainty.plane_normal_at_zero_tilt, "laser std normal");
    ExpectNear(x.uncertainty.tilt_axis, y.uncertainty.tilt_axis, "laser std tilt axis");
    ExpectNear(x.uncertainty.tilt_range_rad, y.uncertainty.tilt_range_rad, "laser std range");
  }
}

// ---- errors ---------------------------------------------------------------

// The message of the FormatError that reading `file` throws; a test failure
// if it throws nothing or anything else.
std::string FormatErrorOf(const fs::path& file) {
  try {
    ReadCalibration(file);
  } catch (const core::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    return e.what();
  } catch (const std::exception& e) {
    ADD_FAILURE() << "not a FormatError: " << e.what();
    return {};
  }
  ADD_FAILURE() << "no FormatError for " << file << ":\n" << Slurp(file).substr(0, 400);
  return {};
}

TEST(Calibration, RoundTripKeepsEveryField) {
  testing::TemporaryDirectory dir;
  const Calibration original = ExampleCalibration();
  WriteCalibration(dir / "calibration.json", original);
  const Calibration read = ReadCalibration(dir / "calibration.json");
  ExpectSame(original, read);
  // Writing what was read gives the same file, byte for byte.
  WriteCalibration(dir / "again.json", read);
  EXPECT_EQ(Slurp(dir / "calibration.json"), Slurp(dir / "again.json"));
  EXPECT_EQ(CountEntries(dir.path()), 2);  // no temporary files left behind
}

TEST(Calibration, FileUsesDegreesAndStdSiblings) {
  const json j = ToJson(ExampleCalibration());
  EXPECT_EQ(j["format"], "mesocap.calibration");
  EXPECT_EQ(j["version"], 2);
  EXPECT_EQ(j["units"], (json{{"length", "mm"}, {"angle", "deg"}}));
  EXPECT_NEAR(j["laser_mounts"][0]["tilt_range_deg"][1].get<double>(), 0.35 * 180 / kPi, 1e-12);
  EXPECT_NEAR(j["laser_mounts"][0]["std"]["tilt_range_deg"][0].get<double>(), 0.001 * 180 / kPi, 1e-15);
  EXPECT_EQ(j["cameras"][0]["intrinsics"]["std"], (json{{"fx", 0.4}, {"cy", 0.25}}));
  EXPECT_FALSE(j["cameras"][1]["intrinsics"].contains("std"));
  EXPECT_EQ(j["cameras"][2]["pose"]["child"], "camera:cam2");
  EXPECT_EQ(j["cameras"][2]["pose"]["std"]["translation_mm"], (json{0.1, 0.2, 0.05}));
  EXPECT_EQ(j["cameras"][0]["radiometry"],
            (json{{"signal_per_radiance_second", 1.6e7}, {"std", {{"signal_per_radiance_second", 2.5e4}}}}));
  EXPECT_EQ(j["cameras"][1]["radiometry"], (json{{"signal_per_radiance_second", 0.75}}));
  EXPECT_FALSE(j["cameras"][2].contains("radiometry"));
}

// Version 1 is version 2 without radiometry: it reads (with none), and
// writing it again gives version 2.
TEST(Calibration, Version1FileLoadsWithoutRadiometry) {
  testing::TemporaryDirectory dir;
  json j = ToJson(ExampleCalibration());
  j["version"] = 1;
  for (auto& camera : j["cameras"]) camera.erase("radiometry");
  Spit(dir / "v1.json", j.dump());
  const Calibration v1 = ReadCalibration(dir / "v1.json");
  Calibration expected = ExampleCalibration();
  for (auto& camera : expected.cameras) camera.radiometry.reset();
  ExpectSame(expected, v1);
  WriteCalibration(dir / "v2.json", v1);
  const json written = json::parse(Slurp(dir / "v2.json"));
  EXPECT_EQ(written["version"], 2);
  for (const auto& camera : written["cameras"]) EXPECT_FALSE(camera.contains("radiometry"));
  ExpectSame(expected, ReadCalibration(dir / "v2.json"));
  // Radiometry is new in version 2.
  j["cameras"][1]["radiometry"] = {{"signal_per_radiance_second", 0.75}};
  Spit(dir / "v1-radiometry.json", j.dump());
  EXPECT_NE(FormatErrorOf(dir / "v1-radiometry.json").find("'cameras[1].radiometry': not in version 1 files"),
            std::string::npos);
}

TEST(Calibration, DirectionsAreNormalizedOnReading) {
  testing::TemporaryDirectory dir;
  json j = ToJson(ExampleCalibration());
  j["turntable"]["axis_direction"] = {0, 0, 2.5};
  j["laser_mounts"][0]["plane_normal_at_zero_tilt"] = {0, 3, 0};
  j["laser_mounts"][0]["tilt_axis"] = {7, 0, -7};
  Spit(dir / "c.json", j.dump());
  const Calibration c = ReadCalibration(dir / "c.json");
  EXPECT_EQ(c.turntable.axis_direction, Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(c.laser_mounts[0].plane_normal_at_zero_tilt, Eigen::Vector3d(0, 1, 0));
  EXPECT_NEAR(c.laser_mounts[0].tilt_axis.norm(), 1, 1e-15);
}

// A hostile or broken edit of a valid file, and the field the error must name.
struct Edit {
  std::string what;
  std::function<void(json&)> apply;
  std::string field;
};

json ListOf(std::size_t n, const json& element) { return json(std::vector<json>(n, element)); }

std::vector<Edit> HostileEdits() {
  using P = json::json_pointer;
  const auto set = [](const std::string& pointer, json value) {
    return [pointer, value](json& j) { j[P(pointer)] = value; };
  };
  const auto erase = [](const std::string& parent, const std::string& key) {
    return [parent, key](json& j) { j[P(parent)].erase(key); };
  };
  return {
      {"other format", set("/format", "mesocap.material"), "format"},
      {"version 3", set("/version", 3), "version"},
      {"version 0", set("/version", 0), "version"},
      {"radiometry in version 1", set("/version", 1), "cameras[0].radiometry"},
      {"version as string", set("/version", "1"), "version"},
      {"no format", erase("", "format"), "format"},
      {"metres", set("/units/length", "m"), "units.length"},
      {"radians", set("/units/angle", "rad"), "units.angle"},
      {"no units", erase("", "units"), "units"},
      {"unknown member", set("/extra", 1), "extra"},
      {"zero width", set("/cameras/0/image_size", {0, 768}), "cameras[0].image_size[0]"},
      {"negative height", set("/cameras/0/image_size", {1024, -768}), "cameras[0].image_size[1]"},
      {"huge width", set("/cameras/0/image_size", {70000, 768}), "cameras[0].image_size[0]"},
      {"1e308 width", set("/cameras/0/image_size", {1e308, 768}), "cameras[0].image_size[0]"},
      {"fractional width", set("/cameras/0/image_size", {1024.5, 768}), "cameras[0].image_size[0]"},
      {"string width", set("/cameras/0/image_size", {"1024", 768}), "cameras[0].image_size[0]"},
      {"null height", set("/cameras/0/image_size", {1024, nullptr}), "cameras[0].image_size[1]"},
      {"one side", set("/cameras/0/image_size", {1024}), "cameras[0].image_size"},
      {"100k sides", set("/cameras/0/image_size", ListOf(100000, 1)), "cameras[0].image_size"},
      {"zero fx", set("/cameras/0/intrinsics/fx", 0), "cameras[0].intrinsics.fx"},
      {"negative fy", set("/cameras/1/intrinsics/fy", -1500), "cameras[1].intrinsics.fy"},
      {"1e308 fx", set("/cameras/0/intrinsics/fx", 1e308), "cameras[0].intrinsics.fx"},
      {"string fx", set("/cameras/0/intrinsics/fx", "1500"), "cameras[0].intrinsics.fx"},
      {"null cx", set("/cameras/0/intrinsics/cx", nullptr), "cameras[0].intrinsics.cx"},
      {"bool cy", set("/cameras/0/intrinsics/cy", true), "cameras[0].intrinsics.cy"},
      {"no cy", erase("/cameras/2/intrinsics", "cy"), "cameras[2].intrinsics.cy"},
      {"intrinsics list", set("/cameras/0/intrinsics", {1, 2, 3, 4}), "cameras[0].intrinsics"},
      {"no k3", erase("/cameras/0/distortion", "k3"), "cameras[0].distortion.k3"},
      {"extra k4", set("/cameras/0/distortion/k4", 0.1), "cameras[0].distortion.k4"},
      {"1e308 k1", set("/cameras/0/distortion/k1", -1e308), "cameras[0].distortion.k1"},
      {"negative std", set("/cameras/0/intrinsics/std/fx", -0.1), "cameras[0].intrinsics.std.fx"},
      {"std of non-parameter", set("/cameras/0/intrinsics/std/k1", 0.1), "cameras[0].intrinsics.std.k1"},
      {"std shape", set("/cameras/0/intrinsics/std/fx", {0.1}), "cameras[0].intrinsics.std.fx"},
      {"std not object", set("/cameras/0/intrinsics/std", 0.4), "cameras[0].intrinsics.std"},
      {"pose std shape", set("/cameras/2/pose/std/rotation_deg", {1, 2}), "cameras[2].pose.std.rotation_deg"},
      {"pose std name", set("/cameras/2/pose/std/rotation", {1, 2, 3}), "cameras[2].pose.std.rotation"},
      {"pose std 1e308", set("/cameras/2/pose/std/translation_mm", {1e308, 0, 0}),
       "cameras[2].pose.std.translation_mm[0]"},
      {"camera parent", set("/cameras/0/pose/parent", "turntable"), "cameras[0].pose.parent"},
      {"camera child", set("/cameras/0/pose/child", "camera:cam1"), "cameras[0].pose.child"},
      {"bad frame", set("/cameras/0/pose/child", "cam0"), "cameras[0].pose.child"},
      {"not a rotation", set("/cameras/0/pose/rotation", {1, 0, 0, 0, 1, 0, 0, 0, 2}), "cameras[0].pose.rotation"},
      {"mirror", set("/cameras/0/pose/rotation", {1, 0, 0, 0, 1, 0, 0, 0, -1}), "cameras[0].pose.rotation"},
      {"1e308 translation", set("/cameras/1/pose/translation_mm", {0, 1e308, 0}), "cameras[1].pose.translation_mm[1]"},
      {"no pose", erase("/cameras/1", "pose"), "cameras[1].pose"},
      {"zero gain", set("/cameras/1/radiometry/signal_per_radiance_second", 0),
       "cameras[1].radiometry.signal_per_radiance_second"},
      {"negative gain", set("/cameras/0/radiometry/signal_per_radiance_second", -1.6e7),
       "cameras[0].radiometry.signal_per_radiance_second"},
      {"NaN gain (null in JSON)", set("/cameras/0/radiometry/signal_per_radiance_second", std::nan("")),
       "cameras[0].radiometry.signal_per_radiance_second"},
      {"string gain", set("/cameras/0/radiometry/signal_per_radiance_second", "1.6e7"),
       "cameras[0].radiometry.signal_per_radiance_second"},
      {"1e308 gain", set("/cameras/1/radiometry/signal_per_radiance_second", 1e308),
       "cameras[1].radiometry.signal_per_radiance_second"},
      {"denormal gain", set("/cameras/1/radiometry/signal_per_radiance_second", 1e-310),
       "cameras[1].radiometry.signal_per_radiance_second"},
      {"no gain", erase("/cameras/1/radiometry", "signal_per_radiance_second"),
       "cameras[1].radiometry.signal_per_radiance_second"},
      {"unknown radiometry member", set("/cameras/0/radiometry/black_level", 0.01),
       "cameras[0].radiometry.black_level"},
      {"radiometry not object", set("/cameras/1/radiometry", 0.75), "cameras[1].radiometry"},
      {"negative gain std", set("/cameras/0/radiometry/std/signal_per_radiance_second", -1),
       "cameras[0].radiometry.std.signal_per_radiance_second"},
      {"gain std of non-parameter", set("/cameras/0/radiometry/std/fx", 1), "cameras[0].radiometry.std.fx"},
      {"duplicate camera",
       [](json& j) {
         j["cameras"][1]["id"] = "cam0";
         j["cameras"][1]["pose"]["child"] = "camera:cam0";
       },
       "cameras[1].id"},
      {"empty id", set("/cameras/0/id", ""), "cameras[0].id"},
      {"id with slash", set("/cameras/0/id", "../cam"), "cameras[0].id"},
      {"numeric id", set("/cameras/0/id", 7), "cameras[0].id"},
      {"no cameras", set("/cameras", json::array()), "cameras"},
      {"null cameras", set("/cameras", nullptr), "cameras"},
      {"257 cameras", [](json& j) { j["cameras"] = ListOf(257, j["cameras"][0]); }, "cameras"},
      {"100k cameras", set("/cameras", ListOf(100000, json::object())), "cameras"},
      {"camera not object", set("/cameras/1", 5), "cameras[1]"},
      {"zero axis", set("/turntable/axis_direction", {0, 0, 0}), "turntable.axis_direction"},
      {"tiny axis", set("/turntable/axis_direction", {0, 1e-300, 0}), "turntable.axis_direction"},
      {"1e308 axis", set("/turntable/axis_direction", {0, 1e308, 1e308}), "turntable.axis_direction[1]"},
      {"sample parent", set("/turntable/sample_pose/parent", "world"), "turntable.sample_pose.parent"},
      {"no turntable", erase("", "turntable"), "turntable"},
      {"string axis point", set("/light_arc/axis_point_mm", {"a", 0, 0}), "light_arc.axis_point_mm[0]"},
      {"arc std unknown", set("/light_arc/std/sample_pose", 1), "light_arc.std.sample_pose"},
      {"negative intensity", set("/lamps/0/intensity", {-1, 0, 0}), "lamps[0].intensity[0]"},
      {"duplicate lamp", set("/lamps/1/id", "halogen0"), "lamps[1].id"},
      {"1e308 lamp", set("/lamps/1/position_mm", {0, 0, 1e308}), "lamps[1].position_mm[2]"},
      {"257 lamps", [](json& j) { j["lamps"] = ListOf(257, j["lamps"][0]); }, "lamps"},
      {"lamps object", set("/lamps", json::object()), "lamps"},
      {"tilt axis off plane", set("/laser_mounts/0/tilt_axis", {0, 1, 0}), "laser_mounts[0].tilt_axis"},
      {"tilt axis slightly off", set("/laser_mounts/0/tilt_axis", {1, 1e-5, 0}), "laser_mounts[0].tilt_axis"},
      {"reversed range", set("/laser_mounts/0/tilt_range_deg", {10, -10}), "laser_mounts[0].tilt_range_deg"},
      {"1e308 range", set("/laser_mounts/1/tilt_range_deg", {0, 1e308}), "laser_mounts[1].tilt_range_deg[1]"},
      {"duplicate mount", set("/laser_mounts/1/id", "mount0"), "laser_mounts[1].id"},
      {"no laser mounts", erase("", "laser_mounts"), "laser_mounts"},
  };
}

TEST(Calibration, HostileEditsNameFileAndField) {
  testing::TemporaryDirectory dir;
  const json valid = ToJson(ExampleCalibration());
  for (const auto& edit : HostileEdits()) {
    SCOPED_TRACE(edit.what);
    json j = valid;
    edit.apply(j);
    const fs::path file = dir / "hostile.json";
    Spit(file, j.dump(2));
    const std::string message = FormatErrorOf(file);
    EXPECT_NE(message.find("'" + edit.field + "'"), std::string::npos) << message;
  }
}

// A 3 MB frame name gave a 3 MB line: the value is echoed cut to 200
// characters.
TEST(Calibration, AHugeFrameNameIsCutInTheMessage) {
  testing::TemporaryDirectory dir;
  json j = ToJson(ExampleCalibration());
  j["cameras"][0]["pose"]["child"] = "camera:" + std::string(3 << 20, 'f');
  Spit(dir / "c.json", j.dump());
  const std::string message = FormatErrorOf(dir / "c.json");
  EXPECT_LT(message.size(), 500u);
  EXPECT_NE(message.find("field 'cameras[0].pose.child': expected \"camera:cam0\" (from id \"cam0\"), got \"camera:" +
                         std::string(193, 'f') + "... (3145735 bytes in all)\""),
            std::string::npos)
      << message;
}

TEST(Calibration, RootThatIsNotAnObject) {
  testing::TemporaryDirectory dir;
  for (const char* text : {"[]", "null", "42", "\"calibration\"", "", "{}"}) {
    Spit(dir / "c.json", text);
    FormatErrorOf(dir / "c.json");
  }
}

// Replaces the value of the first `"key": value` in pretty-printed JSON.
std::string ReplaceValue(std::string text, const std::string& key, const std::string& value) {
  const std::string marker = "\"" + key + "\": ";
  const auto at = text.find(marker);
  const auto start = at + marker.size();
  const auto end = text.find_first_of(",\n", start);
  return text.replace(start, end - start, value);
}

TEST(Calibration, DeepNestingIsRejectedWithoutRecursion) {
  testing::TemporaryDirectory dir;
  const std::string valid = ToJson(ExampleCalibration()).dump(2);
  for (const std::size_t depth : {40, 100000}) {
    SCOPED_TRACE(depth);
    const std::string arrays = std::string(depth, '[') + std::string(depth, ']');
    Spit(dir / "c.json", ReplaceValue(valid, "fx", arrays));
    EXPECT_NE(FormatErrorOf(dir / "c.json").find("nest deeper"), std::string::npos);
    std::string objects;
    for (std::size_t i = 0; i < depth; ++i) objects += "{\"a\":";
    objects += "1" + std::string(depth, '}');
    Spit(dir / "c.json", ReplaceValue(valid, "format", objects));
    EXPECT_NE(FormatErrorOf(dir / "c.json").find("nest deeper"), std::string::npos);
  }
}

TEST(Calibration, NumbersBeyondDoubleAreFormatErrors) {
  testing::TemporaryDirectory dir;
  const std::string valid = ToJson(ExampleCalibration()).dump(2);
  for (const char* number : {"1e400", "-1e99999", "123456789012345678901234567890e300"}) {
    Spit(dir / "c.json", ReplaceValue(valid, "fx", number));
    FormatErrorOf(dir / "c.json");
  }
}

TEST(Calibration, OversizeFileIsRejectedBeforeReading) {
  testing::TemporaryDirectory dir;
  std::string text = ToJson(ExampleCalibration()).dump(2);
  text.resize(kMaxCalibrationBytes + 1, ' ');
  Spit(dir / "c.json", text);
  EXPECT_NE(FormatErrorOf(dir / "c.json").find("at most"), std::string::npos);
}

TEST(Calibration, MissingFileIsAnError) {
  testing::TemporaryDirectory dir;
  EXPECT_NE(FormatErrorOf(dir / "none.json").find("not found"), std::string::npos);
}

TEST(CalibrationFuzz, EveryTruncationIsRejected) {
  testing::TemporaryDirectory dir;
  WriteCalibration(dir / "valid.json", ExampleCalibration());
  const std::string text = Slurp(dir / "valid.json");
  ASSERT_GT(text.size(), 2000u);
  // The file ends "}\n": cutting the newline alone still leaves a valid file.
  const std::size_t stride = text.size() / 700 + 1;
  int tried = 0;
  for (std::size_t n = 0; n + 1 < text.size(); n += (n < 64 || n + 64 > text.size()) ? 1 : stride) {
    Spit(dir / "cut.json", text.substr(0, n));
    FormatErrorOf(dir / "cut.json");
    ++tried;
  }
  EXPECT_GT(tried, 600);
}

TEST(CalibrationFuzz, MutatedBytesAreReadOrRejectedNeverCrash) {
  testing::TemporaryDirectory dir;
  WriteCalibration(dir / "valid.json", ExampleCalibration());
  const std::string text = Slurp(dir / "valid.json");
  std::mt19937 rng(20050601);
  std::uniform_int_distribution<std::size_t> offset(0, text.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  int rejected = 0, accepted = 0;
  for (int i = 0; i < 1500; ++i) {
    std::string mutated = text;
    // Half of the mutations pick a byte that keeps the JSON plausible.
    const char plausible[] = "0123456789-.e,:[]{}\" ";
    mutated[offset(rng)] = i % 2 ? static_cast<char>(byte(rng)) : plausible[byte(rng) % 21];
    const fs::path file = dir / "mutated.json";
    Spit(file, mutated);
    try {
      ReadCalibration(file);
      ++accepted;
    } catch (const core::Error& e) {
      ++rejected;
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a mesocap::Error: " << e.what();
    }
  }
  EXPECT_GT(rejected, 300);
  EXPECT_GT(accepted, 50);  // digits changed into digits stay valid
}

TEST(Calibration, FailedWriteLeavesExistingFileIntact) {
  testing::TemporaryDirectory dir;
  const fs::path file = dir / "calibration.json";
  WriteCalibration(file, ExampleCalibration());
  const std::string before = Slurp(file);

  // Invalid content: refused before anything is written.
  Calibration bad = ExampleCalibration();
  bad.lamps[1].id = bad.lamps[0].id;
  EXPECT_THROW(WriteCalibration(file, bad), core::FormatError);
  bad = ExampleCalibration();
  bad.cameras[0].intrinsics.uncertainty.fx = -1;
  EXPECT_THROW(WriteCalibration(file, bad), core::FormatError);
  bad = ExampleCalibration();
  bad.cameras[0].pose.transform.child_frame = "camera:other";
  EXPECT_THROW(WriteCalibration(file, bad), core::FormatError);
  EXPECT_EQ(Slurp(file), before);
  EXPECT_EQ(CountEntries(dir.path()), 1);

  // A failure while replacing: the target is a folder, so the rename fails.
  fs::create_directories(dir / "occupied.json" / "inside");
  EXPECT_THROW(WriteCalibration(dir / "occupied.json", ExampleCalibration()), core::Error);
  EXPECT_TRUE(fs::is_directory(dir / "occupied.json" / "inside"));
  EXPECT_EQ(CountEntries(dir.path()), 2);  // no temporary file left behind
  EXPECT_EQ(Slurp(file), before);
}

TEST(Calibration, IdsAreSafeInFrameAndFileNames) {
  EXPECT_TRUE(IsValidId("cam0"));
  EXPECT_TRUE(IsValidId("Dragonfly-3_left.v2"));
  EXPECT_TRUE(IsValidId(std::string(128, 'a')));
  EXPECT_FALSE(IsValidId(std::string(129, 'a')));
  EXPECT_FALSE(IsValidId(""));
  EXPECT_FALSE(IsValidId("a/b"));
  EXPECT_FALSE(IsValidId("a b"));
  EXPECT_FALSE(IsValidId("camera:0"));
  EXPECT_FALSE(IsValidId(std::string("a\0b", 3)));
}

}  // namespace
}  // namespace mesocap::formats
