#include "formats/rig_description.h"

#include <Eigen/Geometry>
#include <cmath>
#include <numbers>
#include <set>
#include <sstream>

#include "core/angles.h"
#include "core/error.h"
#include "core/image.h"
#include "core/json_field_reader.h"
#include "formats/calibration.h"

namespace mesocap::formats {
namespace {

constexpr std::size_t kMaxDevices = 256;
constexpr std::size_t kMaxAngles = 4096;
constexpr double kMaxPrincipalPointPx = 1e6;
constexpr double kMaxLampIntensity = 1e12;  // as in a calibration
constexpr double kMaxCalibrationHeightMm = 1e4;

std::vector<double> AnglesDeg(const core::JsonFieldReader& f, std::string_view key, double min_deg, double max_deg) {
  const auto& raw = f.Raw(key);
  if (!raw.is_array() || raw.empty() || raw.size() > kMaxAngles) {
    f.Fail(key, "expected a list of 1 to " + std::to_string(kMaxAngles) + " angles in degrees");
  }
  const auto values = f.Numbers(key, raw.size());
  std::vector<double> out;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (values[i] < min_deg || values[i] > max_deg) {
      std::ostringstream expected;
      expected << "expected an angle in [" << min_deg << ", " << max_deg << "] degrees, got " << values[i];
      f.Fail(std::string(key) + "[" + std::to_string(i) + "]", expected.str());
    }
    out.push_back(core::RadiansFromDegrees(values[i]));
  }
  return out;
}

TicDescription ParseTic(const core::JsonFieldReader& f) {
  TicDescription t;
  t.serial = f.String("serial");
  if (t.serial.empty() || t.serial.size() > 64) f.Fail("serial", "expected the Tic's serial number");
  t.product = f.Has("product") ? f.Choice("product", {"T825", "T834", "T500", "N825", "T249", "36v4"}) : "T825";
  t.full_steps_per_revolution =
      static_cast<int>(f.Has("full_steps_per_revolution") ? f.Integer("full_steps_per_revolution", 1, 100000) : 200);
  t.microsteps = static_cast<int>(f.Has("microsteps") ? f.Integer("microsteps", 1, 256) : 8);
  if ((t.microsteps & (t.microsteps - 1)) != 0) f.Fail("microsteps", "expected a power of two, 1 to 256");
  t.gear_ratio = f.NumberOr("gear_ratio", 1.0, 1e-3, 1e5);
  t.home_forward = f.Has("homing") && f.Choice("homing", {"forward", "reverse"}) == "forward";
  return t;
}

GpioLineDescription ParseGpioLine(const core::JsonFieldReader& f) {
  f.RejectUnknownMembers({"chip", "line", "active_low"});
  GpioLineDescription l;
  l.chip = f.String("chip");
  if (l.chip.empty() || l.chip.size() > 256) f.Fail("chip", "expected a GPIO chip name, path or label");
  const auto& line = f.Raw("line");
  if (line.is_string()) {
    l.name = f.String("line");
    if (l.name.empty()) f.Fail("line", "expected a line offset or name");
  } else {
    l.offset = static_cast<int>(f.Integer("line", 0, 4095));
  }
  l.active_low = f.Has("active_low") && f.Boolean("active_low");
  return l;
}

StepDirDescription ParseStepDir(const core::JsonFieldReader& f) {
  StepDirDescription s;
  s.step = ParseGpioLine(f.Object("step"));
  s.direction = ParseGpioLine(f.Object("direction"));
  s.limit_switch = ParseGpioLine(f.Object("limit_switch"));
  s.full_steps_per_revolution =
      static_cast<int>(f.Has("full_steps_per_revolution") ? f.Integer("full_steps_per_revolution", 1, 100000) : 200);
  s.microsteps = static_cast<int>(f.Has("microsteps") ? f.Integer("microsteps", 1, 256) : 16);
  s.gear_ratio = f.NumberOr("gear_ratio", 1.0, 1e-3, 1e5);
  s.home_forward = f.Has("homing") && f.Choice("homing", {"forward", "reverse"}) == "forward";
  return s;
}

StageDescription ParseStage(const core::JsonFieldReader& f) {
  StageDescription s;
  s.backend = f.Choice("backend", {"sim", "tic"});
  if (s.backend == "tic") {
    f.RejectUnknownMembers({"backend", "angles_deg", "speed_deg_per_s", "serial", "product",
                            "full_steps_per_revolution", "microsteps", "gear_ratio", "homing"});
    s.tic = ParseTic(f);
  } else {
    f.RejectUnknownMembers({"backend", "angles_deg", "speed_deg_per_s"});
  }
  s.angles_rad = AnglesDeg(f, "angles_deg", 0.0, 360.0);
  s.speed_rad_per_s = core::RadiansFromDegrees(f.NumberOr("speed_deg_per_s", 30.0, 1e-3, 3600.0));
  return s;
}

CameraDescription ParseCamera(const core::JsonFieldReader& f) {
  f.RejectUnknownMembers({"id", "backend", "device", "azimuth_deg", "elevation_deg", "distance_mm", "image_size",
                          "focal_px", "principal_point_px", "distortion", "bit_depth", "full_well_electrons",
                          "read_noise_electrons", "exposure_us"});
  CameraDescription c;
  c.id = f.String("id");
  // The id names the camera's files and its calibration entry.
  if (!IsValidId(c.id)) f.Fail("id", "expected an id (1 to 128 characters from A-Z a-z 0-9 . _ -)");
  c.backend = f.Choice("backend", {"sim", "aravis"});
  if (c.backend == "aravis") {
    c.device = f.String("device");
    if (c.device.empty() || c.device.size() > 256) f.Fail("device", "expected an Aravis device id, serial or address");
  } else if (f.Has("device")) {
    f.Fail("device", "only an \"aravis\" camera has a device to open");
  }
  c.azimuth_rad = core::RadiansFromDegrees(f.NumberOr("azimuth_deg", 0.0, -360.0, 360.0));
  c.elevation_rad = core::RadiansFromDegrees(f.Number("elevation_deg", 1.0, 90.0));
  c.distance_mm = f.Number("distance_mm", 1.0, 1e5);
  const auto size = f.Numbers("image_size", 2);
  for (int i = 0; i < 2; ++i) {
    if (size[i] < 8 || size[i] > core::kMaxImageSide || size[i] != std::floor(size[i])) {
      f.Fail("image_size", "expected two whole numbers of pixels in [8, " + std::to_string(core::kMaxImageSide) + "]");
    }
  }
  c.width = static_cast<int>(size[0]);
  c.height = static_cast<int>(size[1]);
  c.focal_px = f.Number("focal_px", 1.0, 1e6);
  c.principal_point_px =
      f.Has("principal_point_px") ? f.Vector2("principal_point_px") : Eigen::Vector2d(c.width / 2.0, c.height / 2.0);
  if (c.principal_point_px.cwiseAbs().maxCoeff() > kMaxPrincipalPointPx) {
    f.Fail("principal_point_px", "expected two numbers in [-1e+06, 1e+06] pixels");
  }
  if (f.Has("distortion")) {
    const auto d = f.Numbers("distortion", 5);
    for (int i = 0; i < 5; ++i) {
      if (std::abs(d[i]) > 10.0) f.Fail("distortion", "expected |k1 k2 p1 p2 k3| <= 10");
      c.distortion[i] = d[i];
    }
  }
  c.bit_depth = static_cast<int>(f.Has("bit_depth") ? f.Integer("bit_depth", 8, 16) : 12);
  c.full_well_electrons = f.NumberOr("full_well_electrons", 20000.0, 1.0, 1e7);
  c.read_noise_electrons = f.NumberOr("read_noise_electrons", 5.0, 0.0, 1e4);
  c.exposure_us = f.NumberOr("exposure_us", 20000.0, 1.0, 1e8);
  return c;
}

// The calibration targets a calibration session photographs, each optional.
void ParseCalibrationTargets(const core::JsonFieldReader& root, RigDescription* rig) {
  if (root.Has("calibration_board")) {
    const auto board = root.Object("calibration_board");
    board.RejectUnknownMembers({"board", "height_mm", "holder_tilts_deg", "turntable_angles_deg"});
    CalibrationBoardDescription b;
    b.board = board.String("board");
    b.height_mm = board.Number("height_mm", 0.0, 1e4);
    b.holder_tilts_rad = AnglesDeg(board, "holder_tilts_deg", -80.0, 80.0);
    if (b.holder_tilts_rad[0] != 0.0)
      board.Fail("holder_tilts_deg[0]", "expected 0: the first tilt sets the sample frame");
    b.turntable_angles_rad = AnglesDeg(board, "turntable_angles_deg", 0.0, 360.0);
    rig->calibration_board = b;
  }
  if (root.Has("white_reference")) {
    const auto white = root.Object("white_reference");
    white.RejectUnknownMembers({"albedo", "height_mm", "arc_angle_deg"});
    WhiteReferenceDescription w;
    w.albedo = white.Number("albedo", 1e-3, 1.0);
    w.height_mm = white.Number("height_mm", -1e4, 1e4);
    w.arc_angle_rad = core::RadiansFromDegrees(white.Number("arc_angle_deg", 0.0, 360.0));
    rig->white_reference = w;
  }
  if (root.Has("mirror_sphere")) {
    const auto sphere = root.Object("mirror_sphere");
    sphere.RejectUnknownMembers({"radius_mm", "offset_mm", "centre_height_mm", "turntable_angles_deg", "arc_angles_deg",
                                 "reflectance", "exposure_us"});
    MirrorSphereDescription m;
    m.radius_mm = sphere.Number("radius_mm", 0.1, 1e3);
    m.offset_mm = sphere.Number("offset_mm", 0.0, 1e4);
    m.turntable_angles_rad = AnglesDeg(sphere, "turntable_angles_deg", 0.0, 360.0);
    if (sphere.Has("arc_angles_deg")) m.arc_angles_rad = AnglesDeg(sphere, "arc_angles_deg", 0.0, 360.0);
    m.centre_height_mm = sphere.Number("centre_height_mm", -1e4, 1e4);
    m.reflectance = sphere.Number("reflectance", 1e-3, 1.0);
    m.exposure_us = sphere.Number("exposure_us", 1.0, 1e7);
    rig->mirror_sphere = m;
  }
}

LampBankDescription ParseLamps(const core::JsonFieldReader& lamps) {
  LampBankDescription bank;
  bank.backend = lamps.Choice("backend", {"sim", "gpiod"});
  if (bank.backend == "gpiod") {
    lamps.RejectUnknownMembers({"backend", "distance_mm", "elevations_deg", "intensity", "emitter_radius_mm", "lines",
                                "sense_lines", "settle_ms"});
  } else {
    lamps.RejectUnknownMembers({"backend", "distance_mm", "elevations_deg", "intensity", "emitter_radius_mm"});
  }
  if (lamps.Has("emitter_radius_mm")) bank.emitter_radius_mm = lamps.Number("emitter_radius_mm", 0.01, 1e4);
  bank.distance_mm = lamps.Number("distance_mm", 1.0, 1e5);
  bank.elevations_rad = AnglesDeg(lamps, "elevations_deg", 1.0, 90.0);
  if (bank.backend == "gpiod") {
    for (const auto& line : lamps.Objects("lines", kMaxDevices)) bank.lines.push_back(ParseGpioLine(line));
    if (bank.lines.size() != bank.elevations_rad.size()) {
      lamps.Fail("lines", "expected one line per lamp (" + std::to_string(bank.elevations_rad.size()) + ")");
    }
    if (lamps.Has("sense_lines")) {
      for (const auto& line : lamps.Objects("sense_lines", kMaxDevices)) {
        bank.sense_lines.push_back(ParseGpioLine(line));
      }
      if (bank.sense_lines.size() != bank.lines.size()) {
        lamps.Fail("sense_lines", "expected one sense line per lamp (" + std::to_string(bank.lines.size()) + ")");
      }
    }
    bank.settle_ms = lamps.NumberOr("settle_ms", 200.0, 0.0, 600000.0);
  }
  bank.intensity = lamps.Vector3("intensity");
  if (bank.intensity.minCoeff() < 0 || bank.intensity.maxCoeff() > kMaxLampIntensity) {
    lamps.Fail("intensity", "expected three numbers in [0, 1e+12]");
  }
  return bank;
}

LaserDescription ParseLaser(const core::JsonFieldReader& laser) {
  LaserDescription l;
  l.backend = laser.Choice("backend", {"sim", "gpiod"});
  if (l.backend == "gpiod") {
    laser.RejectUnknownMembers({"backend", "distance_mm", "mount_elevations_deg", "locations", "sweep_mm",
                                "frames_per_sweep", "stripe_sigma_mm", "power", "calibration_heights_mm",
                                "sweep_storage", "enable", "tilt"});
  } else {
    laser.RejectUnknownMembers({"backend", "distance_mm", "mount_elevations_deg", "locations", "sweep_mm",
                                "frames_per_sweep", "stripe_sigma_mm", "power", "calibration_heights_mm",
                                "sweep_storage"});
  }
  if (l.backend == "gpiod") {
    l.enable = ParseGpioLine(laser.Object("enable"));
    const auto tilt = laser.Object("tilt");
    l.tilt_backend = tilt.Choice("backend", {"tic", "gpiod"});
    if (l.tilt_backend == "tic") {
      tilt.RejectUnknownMembers(
          {"backend", "serial", "product", "full_steps_per_revolution", "microsteps", "gear_ratio", "homing"});
      l.tilt_tic = ParseTic(tilt);
    } else {
      tilt.RejectUnknownMembers({"backend", "step", "direction", "limit_switch", "full_steps_per_revolution",
                                 "microsteps", "gear_ratio", "homing"});
      l.tilt_stepper = ParseStepDir(tilt);
    }
  }
  l.distance_mm = laser.Number("distance_mm", 1.0, 1e5);
  l.mount_elevations_rad = AnglesDeg(laser, "mount_elevations_deg", 1.0, 89.0);
  for (const auto& loc : laser.Objects("locations", kMaxAngles)) {
    loc.RejectUnknownMembers({"mount", "arc_angle_deg"});
    LaserLocation location;
    location.mount = static_cast<int>(loc.Integer("mount", 0, static_cast<int>(l.mount_elevations_rad.size()) - 1));
    location.arc_angle_rad = core::RadiansFromDegrees(loc.Number("arc_angle_deg", -360.0, 360.0));
    l.locations.push_back(location);
  }
  if (l.locations.empty()) laser.Fail("locations", "expected at least one laser source location");
  const auto sweep = laser.Numbers("sweep_mm", 2);
  if (!(sweep[0] < sweep[1]) || std::abs(sweep[0]) > l.distance_mm || std::abs(sweep[1]) > l.distance_mm) {
    laser.Fail("sweep_mm", "expected [min, max] with min < max, both within the laser distance");
  }
  l.sweep_min_mm = sweep[0];
  l.sweep_max_mm = sweep[1];
  l.frames_per_sweep = static_cast<int>(laser.Integer("frames_per_sweep", 2, 100000));
  l.stripe_sigma_mm = laser.Number("stripe_sigma_mm", 1e-4, 100.0);
  l.power = laser.NumberOr("power", 1.0, 0.0, 1e6);
  const auto heights = laser.Numbers("calibration_heights_mm", 2);
  if (!(heights[0] != heights[1]) || std::min(heights[0], heights[1]) < 0 ||
      std::max(heights[0], heights[1]) > kMaxCalibrationHeightMm) {
    laser.Fail("calibration_heights_mm", "expected two different heights in [0, 10000] mm");
  }
  l.calibration_heights_mm = {heights[0], heights[1]};
  if (laser.Has("sweep_storage") && laser.Choice("sweep_storage", {"frames", "analysis"}) == "analysis") {
    l.sweep_storage = LaserDescription::SweepStorage::kAnalysis;
  }
  return l;
}

}  // namespace

RigDescription ParseRigDescription(const nlohmann::json& json, const std::filesystem::path& file) {
  const core::JsonFieldReader root(json, file);
  root.ExpectFormat("mesocap.rig", 1);
  root.RejectUnknownMembers({"format", "version", "name", "sample", "cameras", "turntable", "light_arc", "lamps",
                             "laser", "faults", "calibration_board", "white_reference", "mirror_sphere"});
  RigDescription rig;
  rig.json = json;
  rig.file = file;
  rig.name = root.String("name");
  const auto sample = root.Object("sample");
  sample.RejectUnknownMembers({"size_mm", "backing"});
  rig.sample_size_mm = sample.Number("size_mm", 1e-3, 1e4);
  if (sample.Has("backing")) {
    const auto backing = sample.Object("backing");
    backing.RejectUnknownMembers({"depth_mm", "albedo"});
    rig.backing.depth_mm = backing.Number("depth_mm", 1e-3, 1e4);
    rig.backing.albedo = backing.Number("albedo", 0.0, 1.0);
  }

  ParseCalibrationTargets(root, &rig);

  std::set<std::string> ids;
  for (const auto& c : root.Objects("cameras", kMaxDevices)) {
    rig.cameras.push_back(ParseCamera(c));
    if (!ids.insert(rig.cameras.back().id).second)
      c.Fail("id", "duplicate camera id " + core::Quoted(rig.cameras.back().id));
  }
  if (rig.cameras.empty()) root.Fail("cameras", "expected at least one camera");
  rig.turntable = ParseStage(root.Object("turntable"));
  rig.light_arc = ParseStage(root.Object("light_arc"));
  if (rig.mirror_sphere && rig.mirror_sphere->arc_angles_rad.empty()) {
    rig.mirror_sphere->arc_angles_rad = rig.light_arc.angles_rad;
  }

  rig.lamps = ParseLamps(root.Object("lamps"));
  rig.laser = ParseLaser(root.Object("laser"));
  return rig;
}

RigDescription ReadRigDescription(const std::filesystem::path& file) {
  return ParseRigDescription(core::ReadJsonFile(file, 4ull << 20), file);
}

}  // namespace mesocap::formats
