#include "formats/calibration.h"

#include <cmath>
#include <map>
#include <numbers>
#include <set>
#include <type_traits>
#include <utility>

#include "core/angles.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_field_reader.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kCalibrationFormat = "mesocap.calibration";
constexpr int kCalibrationVersion = 2;
// Version 1 is version 2 without cameras' "radiometry".
constexpr int kOldestCalibrationVersion = 1;
// The deepest valid calibration nests 6 levels (root, cameras, camera, pose,
// std, translation_mm); anything far deeper is hostile.
constexpr int kCalibrationMaxDepth = 32;

// Bounds that catch garbage such as 1e308 while leaving room for any real rig.
constexpr double kMaxLengthMm = 1e6;  // 1 km
constexpr double kMaxDirectionComponent = 1e6;
constexpr double kMinDirectionLength = 1e-6;
constexpr double kUnitTolerance = 1e-12;
constexpr double kMaxPixels = 1e7;
constexpr double kMaxDistortion = 1e6;
constexpr double kMaxIntensity = 1e12;
constexpr double kMaxAngleDeg = 180;
// Wider than core::kMaxImageSide: a calibration may describe any camera, also
// one calibrated by another tool that mesocap never captures with.
constexpr int kMaxCalibratedImageSide = 65536;
// |n . a| for a tilt axis in the laser plane, after normalizing both.
constexpr double kInPlaneTolerance = 1e-6;

// ---- reading --------------------------------------------------------------

Eigen::Vector3d Position(const core::JsonFieldReader& fields, std::string_view key) {
  const auto v = fields.Numbers(key, 3, -kMaxLengthMm, kMaxLengthMm);
  return {v[0], v[1], v[2]};
}

// A direction of any non-zero length, returned as a unit vector. One that is
// unit already is kept bit for bit, so reading and writing again is stable.
Eigen::Vector3d Direction(const core::JsonFieldReader& fields, std::string_view key) {
  const auto v = fields.Numbers(key, 3, -kMaxDirectionComponent, kMaxDirectionComponent);
  const Eigen::Vector3d d(v[0], v[1], v[2]);
  const double length = d.norm();
  if (length < kMinDirectionLength) fields.Fail(key, "expected a non-zero direction");
  return std::abs(length - 1) <= kUnitTolerance ? d : Eigen::Vector3d(d / length);
}

double PositiveNumber(const core::JsonFieldReader& fields, std::string_view key, double max) {
  const double x = fields.Number(key, 0, max);
  if (x <= 0) fields.Fail(key, "expected a number > 0, got 0");
  return x;
}

std::string Id(const core::JsonFieldReader& fields) {
  const std::string id = fields.String("id");
  if (!IsValidId(id)) {
    fields.Fail("id", "expected 1 to 128 characters from A-Z a-z 0-9 . _ -");
  }
  return id;
}

// A parameter that a "std" object may name: its key, how many numbers it
// holds, and the largest standard deviation that makes sense for it.
struct Parameter {
  std::string_view key;
  std::size_t count;
  double max_std;
};

// The standard deviations given in the object's optional "std" member.
using Deviations = std::map<std::string, std::vector<double>, std::less<>>;

Deviations ReadDeviations(const core::JsonFieldReader& object, std::initializer_list<Parameter> parameters) {
  Deviations out;
  if (!object.Has("std")) return out;
  const core::JsonFieldReader std_fields = object.Object("std");
  for (const auto& [key, value] : std_fields.json().items()) {
    const Parameter* match = nullptr;
    for (const auto& p : parameters) {
      if (p.key == key) match = &p;
    }
    if (!match) {
      std::string list;
      for (const auto& p : parameters) list += (list.empty() ? "" : ", ") + std::string(p.key);
      std_fields.Fail(key, "not a parameter of this object; expected one of " + list);
    }
    out[key] = match->count == 1 ? std::vector<double>{std_fields.Number(key, 0, match->max_std)}
                                 : std_fields.Numbers(key, match->count, 0, match->max_std);
  }
  return out;
}

std::optional<double> Deviation1(const Deviations& d, std::string_view key, double scale = 1) {
  const auto it = d.find(key);
  if (it == d.end()) return std::nullopt;
  return it->second[0] * scale;
}

std::optional<Eigen::Vector3d> Deviation3(const Deviations& d, std::string_view key, double scale = 1) {
  const auto it = d.find(key);
  if (it == d.end()) return std::nullopt;
  return Eigen::Vector3d(it->second[0], it->second[1], it->second[2]) * scale;
}

std::optional<Eigen::Vector2d> Deviation2(const Deviations& d, std::string_view key, double scale = 1) {
  const auto it = d.find(key);
  if (it == d.end()) return std::nullopt;
  return Eigen::Vector2d(it->second[0], it->second[1]) * scale;
}

// `child_source` says where the expected child frame comes from ("id \"cam0\"").
CalibratedPose ReadPose(const core::JsonFieldReader& fields, const std::string& parent, const std::string& child,
                        const std::string& child_source = "") {
  fields.RejectUnknownMembers({"parent", "child", "rotation", "translation_mm", "std"});
  CalibratedPose pose;
  pose.transform = core::ReadRigidTransform(fields);
  if (pose.transform.parent_frame != parent) {
    fields.Fail("parent", "expected \"" + parent + "\", got " + core::Quoted(pose.transform.parent_frame));
  }
  if (pose.transform.child_frame != child) {
    fields.Fail("child", "expected " + core::Quoted(child) +
                             (child_source.empty() ? "" : " (from " + child_source + ")") + ", got " +
                             core::Quoted(pose.transform.child_frame));
  }
  Position(fields, "translation_mm");  // bounds only; ReadRigidTransform read the values
  const auto d = ReadDeviations(fields, {{"rotation_deg", 3, kMaxAngleDeg}, {"translation_mm", 3, kMaxLengthMm}});
  pose.uncertainty.rotation_rad = Deviation3(d, "rotation_deg", core::RadiansFromDegrees(1.0));
  pose.uncertainty.translation_mm = Deviation3(d, "translation_mm");
  return pose;
}

Intrinsics ReadIntrinsics(const core::JsonFieldReader& fields) {
  fields.RejectUnknownMembers({"fx", "fy", "cx", "cy", "std"});
  Intrinsics k;
  k.fx = PositiveNumber(fields, "fx", kMaxPixels);
  k.fy = PositiveNumber(fields, "fy", kMaxPixels);
  k.cx = fields.Number("cx", -kMaxPixels, kMaxPixels);
  k.cy = fields.Number("cy", -kMaxPixels, kMaxPixels);
  const auto d = ReadDeviations(
      fields, {{"fx", 1, kMaxPixels}, {"fy", 1, kMaxPixels}, {"cx", 1, kMaxPixels}, {"cy", 1, kMaxPixels}});
  k.uncertainty = {Deviation1(d, "fx"), Deviation1(d, "fy"), Deviation1(d, "cx"), Deviation1(d, "cy")};
  return k;
}

Distortion ReadDistortion(const core::JsonFieldReader& fields) {
  fields.RejectUnknownMembers({"k1", "k2", "p1", "p2", "k3", "std"});
  Distortion k;
  k.k1 = fields.Number("k1", -kMaxDistortion, kMaxDistortion);
  k.k2 = fields.Number("k2", -kMaxDistortion, kMaxDistortion);
  k.p1 = fields.Number("p1", -kMaxDistortion, kMaxDistortion);
  k.p2 = fields.Number("p2", -kMaxDistortion, kMaxDistortion);
  k.k3 = fields.Number("k3", -kMaxDistortion, kMaxDistortion);
  const auto d = ReadDeviations(fields, {{"k1", 1, kMaxDistortion},
                                         {"k2", 1, kMaxDistortion},
                                         {"p1", 1, kMaxDistortion},
                                         {"p2", 1, kMaxDistortion},
                                         {"k3", 1, kMaxDistortion}});
  k.uncertainty = {Deviation1(d, "k1"), Deviation1(d, "k2"), Deviation1(d, "p1"), Deviation1(d, "p2"),
                   Deviation1(d, "k3")};
  return k;
}

CameraRadiometry ReadRadiometry(const core::JsonFieldReader& fields) {
  fields.RejectUnknownMembers({"signal_per_radiance_second", "std"});
  CameraRadiometry r;
  r.signal_per_radiance_second = fields.Number("signal_per_radiance_second", kMinCameraGain, kMaxCameraGain);
  const auto d = ReadDeviations(fields, {{"signal_per_radiance_second", 1, kMaxCameraGain}});
  r.uncertainty.signal_per_radiance_second = Deviation1(d, "signal_per_radiance_second");
  return r;
}

CameraCalibration ReadCamera(const core::JsonFieldReader& fields, int version) {
  if (version >= 2) {
    fields.RejectUnknownMembers({"id", "image_size", "intrinsics", "distortion", "pose", "radiometry"});
  } else {
    if (fields.Has("radiometry")) fields.Fail("radiometry", "not in version 1 files; expected version 2");
    fields.RejectUnknownMembers({"id", "image_size", "intrinsics", "distortion", "pose"});
  }
  CameraCalibration c;
  c.id = Id(fields);
  const auto size = fields.Numbers("image_size", 2, 1, kMaxCalibratedImageSide);
  for (int i = 0; i < 2; ++i) {
    if (size[i] != std::floor(size[i])) {
      fields.Fail("image_size[" + std::to_string(i) + "]", "expected a whole number of pixels");
    }
  }
  c.width = static_cast<int>(size[0]);
  c.height = static_cast<int>(size[1]);
  c.intrinsics = ReadIntrinsics(fields.Object("intrinsics"));
  c.distortion = ReadDistortion(fields.Object("distortion"));
  c.pose = ReadPose(fields.Object("pose"), "world", "camera:" + c.id, "id " + core::Quoted(c.id));
  if (fields.Has("radiometry")) c.radiometry = ReadRadiometry(fields.Object("radiometry"));
  return c;
}

TurntableCalibration ReadTurntable(const core::JsonFieldReader& fields) {
  fields.RejectUnknownMembers({"axis_point_mm", "axis_direction", "sample_pose", "std"});
  TurntableCalibration t;
  t.axis_point_mm = Position(fields, "axis_point_mm");
  t.axis_direction = Direction(fields, "axis_direction");
  t.sample_pose = ReadPose(fields.Object("sample_pose"), "turntable", "sample");
  const auto d =
      ReadDeviations(fields, {{"axis_point_mm", 3, kMaxLengthMm}, {"axis_direction", 3, kMaxDirectionComponent}});
  t.uncertainty = {Deviation3(d, "axis_point_mm"), Deviation3(d, "axis_direction")};
  return t;
}

LightArcCalibration ReadLightArc(const core::JsonFieldReader& fields) {
  fields.RejectUnknownMembers({"axis_point_mm", "axis_direction", "std"});
  LightArcCalibration a;
  a.axis_point_mm = Position(fields, "axis_point_mm");
  a.axis_direction = Direction(fields, "axis_direction");
  const auto d =
      ReadDeviations(fields, {{"axis_point_mm", 3, kMaxLengthMm}, {"axis_direction", 3, kMaxDirectionComponent}});
  a.uncertainty = {Deviation3(d, "axis_point_mm"), Deviation3(d, "axis_direction")};
  return a;
}

LampCalibration ReadLamp(const core::JsonFieldReader& fields) {
  fields.RejectUnknownMembers({"id", "position_mm", "intensity", "std"});
  LampCalibration l;
  l.id = Id(fields);
  l.position_mm = Position(fields, "position_mm");
  const auto i = fields.Numbers("intensity", 3, 0, kMaxIntensity);
  l.intensity = {i[0], i[1], i[2]};
  const auto d = ReadDeviations(fields, {{"position_mm", 3, kMaxLengthMm}, {"intensity", 3, kMaxIntensity}});
  l.uncertainty = {Deviation3(d, "position_mm"), Deviation3(d, "intensity")};
  return l;
}

LaserMountCalibration ReadLaserMount(const core::JsonFieldReader& fields) {
  fields.RejectUnknownMembers({"id", "source_mm", "plane_normal_at_zero_tilt", "tilt_axis", "tilt_range_deg", "std"});
  LaserMountCalibration m;
  m.id = Id(fields);
  m.source_mm = Position(fields, "source_mm");
  m.plane_normal_at_zero_tilt = Direction(fields, "plane_normal_at_zero_tilt");
  m.tilt_axis = Direction(fields, "tilt_axis");
  if (std::abs(m.plane_normal_at_zero_tilt.dot(m.tilt_axis)) >= kInPlaneTolerance) {
    fields.Fail("tilt_axis",
                "expected a direction in the laser plane (perpendicular to "
                "plane_normal_at_zero_tilt)");
  }
  const auto range = fields.Numbers("tilt_range_deg", 2, -kMaxAngleDeg, kMaxAngleDeg);
  if (range[0] >= range[1]) fields.Fail("tilt_range_deg", "expected [min, max] with min < max");
  m.tilt_range_rad = Eigen::Vector2d(core::RadiansFromDegrees(range[0]), core::RadiansFromDegrees(range[1]));
  const auto d = ReadDeviations(fields, {{"source_mm", 3, kMaxLengthMm},
                                         {"plane_normal_at_zero_tilt", 3, kMaxDirectionComponent},
                                         {"tilt_axis", 3, kMaxDirectionComponent},
                                         {"tilt_range_deg", 2, kMaxAngleDeg}});
  m.uncertainty = {Deviation3(d, "source_mm"), Deviation3(d, "plane_normal_at_zero_tilt"), Deviation3(d, "tilt_axis"),
                   Deviation2(d, "tilt_range_deg", core::RadiansFromDegrees(1.0))};
  return m;
}

// Reads each element of the list `key` with `read`; ids must be unique.
template <typename Part, typename ReadPart>
std::vector<Part> ReadParts(const core::JsonFieldReader& root, std::string_view key, ReadPart read) {
  std::vector<Part> parts;
  std::set<std::string> ids;
  for (const auto& fields : root.Objects(key, kMaxRigParts)) {
    parts.push_back(read(fields));
    if (!ids.insert(parts.back().id).second) {
      fields.Fail("id", "duplicate id " + core::Quoted(parts.back().id));
    }
  }
  return parts;
}

Calibration ParseCalibration(const json& document, const fs::path& file) {
  const core::JsonFieldReader root(document, file);
  const int version = root.ExpectFormat(kCalibrationFormat, kOldestCalibrationVersion, kCalibrationVersion);
  root.RejectUnknownMembers(
      {"format", "version", "units", "cameras", "turntable", "light_arc", "lamps", "laser_mounts"});
  const core::JsonFieldReader units = root.Object("units");
  units.RejectUnknownMembers({"length", "angle"});
  units.Choice("length", {"mm"});
  units.Choice("angle", {"deg"});

  Calibration c;
  c.cameras = ReadParts<CameraCalibration>(
      root, "cameras", [version](const core::JsonFieldReader& fields) { return ReadCamera(fields, version); });
  if (c.cameras.empty()) root.Fail("cameras", "expected at least one camera");
  c.turntable = ReadTurntable(root.Object("turntable"));
  c.light_arc = ReadLightArc(root.Object("light_arc"));
  c.lamps = ReadParts<LampCalibration>(root, "lamps", ReadLamp);
  c.laser_mounts = ReadParts<LaserMountCalibration>(root, "laser_mounts", ReadLaserMount);
  return c;
}

// ---- writing --------------------------------------------------------------

json NumberList(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }
json NumberList(const Eigen::Vector2d& v) { return {v.x(), v.y()}; }

// Angles in radians (or their deviations), written in degrees.
template <typename T>
T InDegrees(const T& radians) {
  return radians.unaryExpr([](double r) { return core::DegreesFromRadians(r); });
}
template <typename T>
std::optional<T> InDegrees(const std::optional<T>& radians) {
  if (!radians) return std::nullopt;
  return InDegrees(*radians);
}

// Adds `value` under `key` to the "std" object being built, when present.
template <typename T>
void PutDeviation(json& std_json, const char* key, const std::optional<T>& value) {
  if (!value) return;
  if constexpr (std::is_same_v<T, double>) {
    std_json[key] = *value;
  } else {
    std_json[key] = NumberList(*value);
  }
}

// Attaches a non-empty "std" object.
void AttachDeviations(json& object, json std_json) {
  if (!std_json.empty()) object["std"] = std::move(std_json);
}

json PoseJson(const CalibratedPose& pose) {
  json j = ToJson(pose.transform);
  json d = json::object();
  PutDeviation(d, "rotation_deg", InDegrees(pose.uncertainty.rotation_rad));
  PutDeviation(d, "translation_mm", pose.uncertainty.translation_mm);
  AttachDeviations(j, std::move(d));
  return j;
}

json CameraJson(const CameraCalibration& c) {
  const auto& k = c.intrinsics;
  json intrinsics = {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}};
  json d = json::object();
  PutDeviation(d, "fx", k.uncertainty.fx);
  PutDeviation(d, "fy", k.uncertainty.fy);
  PutDeviation(d, "cx", k.uncertainty.cx);
  PutDeviation(d, "cy", k.uncertainty.cy);
  AttachDeviations(intrinsics, std::move(d));

  const auto& t = c.distortion;
  json distortion = {{"k1", t.k1}, {"k2", t.k2}, {"p1", t.p1}, {"p2", t.p2}, {"k3", t.k3}};
  d = json::object();
  PutDeviation(d, "k1", t.uncertainty.k1);
  PutDeviation(d, "k2", t.uncertainty.k2);
  PutDeviation(d, "p1", t.uncertainty.p1);
  PutDeviation(d, "p2", t.uncertainty.p2);
  PutDeviation(d, "k3", t.uncertainty.k3);
  AttachDeviations(distortion, std::move(d));

  json j = {{"id", c.id},
            {"image_size", {c.width, c.height}},
            {"intrinsics", std::move(intrinsics)},
            {"distortion", std::move(distortion)},
            {"pose", PoseJson(c.pose)}};
  if (c.radiometry) {
    json radiometry = {{"signal_per_radiance_second", c.radiometry->signal_per_radiance_second}};
    d = json::object();
    PutDeviation(d, "signal_per_radiance_second", c.radiometry->uncertainty.signal_per_radiance_second);
    AttachDeviations(radiometry, std::move(d));
    j["radiometry"] = std::move(radiometry);
  }
  return j;
}

// A rotation axis (the turntable's, the light arc's) with its deviations.
template <typename Axis>
json AxisJson(const Axis& a) {
  json j = {{"axis_point_mm", NumberList(a.axis_point_mm)}, {"axis_direction", NumberList(a.axis_direction)}};
  json d = json::object();
  PutDeviation(d, "axis_point_mm", a.uncertainty.axis_point_mm);
  PutDeviation(d, "axis_direction", a.uncertainty.axis_direction);
  AttachDeviations(j, std::move(d));
  return j;
}

json TurntableJson(const TurntableCalibration& t) {
  json j = AxisJson(t);
  j["sample_pose"] = PoseJson(t.sample_pose);
  return j;
}

json LampJson(const LampCalibration& l) {
  json j = {{"id", l.id}, {"position_mm", NumberList(l.position_mm)}, {"intensity", NumberList(l.intensity)}};
  json d = json::object();
  PutDeviation(d, "position_mm", l.uncertainty.position_mm);
  PutDeviation(d, "intensity", l.uncertainty.intensity);
  AttachDeviations(j, std::move(d));
  return j;
}

json LaserMountJson(const LaserMountCalibration& m) {
  json j = {{"id", m.id},
            {"source_mm", NumberList(m.source_mm)},
            {"plane_normal_at_zero_tilt", NumberList(m.plane_normal_at_zero_tilt)},
            {"tilt_axis", NumberList(m.tilt_axis)},
            {"tilt_range_deg", NumberList(InDegrees(m.tilt_range_rad))}};
  json d = json::object();
  PutDeviation(d, "source_mm", m.uncertainty.source_mm);
  PutDeviation(d, "plane_normal_at_zero_tilt", m.uncertainty.plane_normal_at_zero_tilt);
  PutDeviation(d, "tilt_axis", m.uncertainty.tilt_axis);
  PutDeviation(d, "tilt_range_deg", InDegrees(m.uncertainty.tilt_range_rad));
  AttachDeviations(j, std::move(d));
  return j;
}

template <typename Part, typename ToPartJson>
json ListJson(const std::vector<Part>& parts, ToPartJson to_json) {
  json list = json::array();
  for (const auto& p : parts) list.push_back(to_json(p));
  return list;
}

}  // namespace

bool IsValidId(std::string_view id) {
  if (id.empty() || id.size() > 128) return false;
  for (const char ch : id) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '.' ||
                    ch == '_' || ch == '-';
    if (!ok) return false;
  }
  return true;
}

json ToJson(const Calibration& c) {
  return {{"format", kCalibrationFormat},
          {"version", kCalibrationVersion},
          {"units", {{"length", "mm"}, {"angle", "deg"}}},
          {"cameras", ListJson(c.cameras, CameraJson)},
          {"turntable", TurntableJson(c.turntable)},
          {"light_arc", AxisJson(c.light_arc)},
          {"lamps", ListJson(c.lamps, LampJson)},
          {"laser_mounts", ListJson(c.laser_mounts, LaserMountJson)}};
}

bool IsCalibrationFile(const fs::path& file) {
  return core::JsonFileHolds(file, [](const json& doc) {
    return doc.is_object() && doc.contains("format") && doc["format"] == kCalibrationFormat;
  });
}

Calibration ReadCalibration(const fs::path& file) {
  return ParseCalibration(core::ReadJsonFile(file, kMaxCalibrationBytes, kCalibrationMaxDepth), file);
}

std::string CalibrationText(const Calibration& calibration) {
  const json document = ToJson(calibration);
  ParseCalibration(document, "calibration");
  return document.dump(2) + "\n";
}

void WriteCalibration(const fs::path& file, const Calibration& calibration) {
  const json document = ToJson(calibration);
  ParseCalibration(document, file);
  core::WriteTextFileAtomically(file, document.dump(2) + "\n");
}

}  // namespace mesocap::formats
