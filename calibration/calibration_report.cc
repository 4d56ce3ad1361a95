#include "calibration/calibration_report.h"

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <sstream>

#include "core/angles.h"

namespace mesocap::calibration {
namespace {

nlohmann::json OrNull(const std::optional<double>& value) {
  return value ? nlohmann::json(*value) : nlohmann::json(nullptr);
}

nlohmann::json Vector(const Eigen::Vector3d& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }

nlohmann::json SetAside(const std::vector<SetAsideImage>& images) {
  nlohmann::json list = nlohmann::json::array();
  for (const SetAsideImage& image : images) list.push_back({{"file", image.name}, {"reason", image.reason}});
  return list;
}

std::string Line(const char* format, ...) __attribute__((format(printf, 1, 2)));
std::string Line(const char* format, ...) {
  char buffer[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof buffer, format, args);
  va_end(args);
  return buffer;
}

nlohmann::json LadderJson(const CalibratedCamera& camera) {
  nlohmann::json ladder = nlohmann::json::array();
  for (const DistortionRung& rung : camera.distortion_ladder) {
    ladder.push_back({{"model", ToString(rung.model)},
                      {"terms", TermCount(rung.model)},
                      {"rms_px", rung.rms_px},
                      {"aic", rung.aic},
                      {"chosen", rung.model == camera.distortion_model}});
  }
  return ladder;
}

nlohmann::json CameraEntries(const CalibrationReport& report) {
  nlohmann::json cameras = nlohmann::json::array();
  for (std::size_t c = 0; c < report.cameras.cameras.size(); ++c) {
    const CalibratedCamera& camera = report.cameras.cameras[c];
    const formats::Intrinsics& k = camera.calibration.intrinsics;
    const formats::Distortion& d = camera.calibration.distortion;
    nlohmann::json entry = {
        {"id", camera.calibration.id},
        {"width", camera.calibration.width},
        {"height", camera.calibration.height},
        {"images_used", camera.images_used},
        {"outlier_images", SetAside(camera.outlier_images)},
        {"unused_images", SetAside(camera.unused_images)},
        {"corners_used", camera.corners_used},
        {"outlier_corners", camera.outlier_corners},
        {"rms_px", camera.rms_px},
        {"fx", k.fx},
        {"fy", k.fy},
        {"cx", k.cx},
        {"cy", k.cy},
        {"k1", d.k1},
        {"k2", d.k2},
        {"p1", d.p1},
        {"p2", d.p2},
        {"k3", d.k3},
        {"std",
         {{"fx", OrNull(k.uncertainty.fx)},
          {"fy", OrNull(k.uncertainty.fy)},
          {"cx", OrNull(k.uncertainty.cx)},
          {"cy", OrNull(k.uncertainty.cy)},
          {"k1", OrNull(d.uncertainty.k1)},
          {"k2", OrNull(d.uncertainty.k2)},
          {"p1", OrNull(d.uncertainty.p1)},
          {"p2", OrNull(d.uncertainty.p2)},
          {"k3", OrNull(d.uncertainty.k3)}}},
        {"distortion_model", ToString(camera.distortion_model)},
        {"distortion_ladder", LadderJson(camera)},
        {"undetermined_terms", camera.undetermined_terms},
        {"working_distance_mm", camera.working_distance_mm},
        {"projection_uncertainty_px",
         k.uncertainty.fx ? nlohmann::json(camera.projection_uncertainty_px) : nlohmann::json(nullptr)},
        {"cross_validation_px", nullptr},
        {"cross_validation_mm", nullptr}};
    if (report.cross_validation) {
      entry["cross_validation_px"] = (*report.cross_validation)[c].rms_px;
      entry["cross_validation_max_px"] = (*report.cross_validation)[c].max_px;
      entry["cross_validation_mm"] = (*report.cross_validation)[c].rms_mm;
    }
    if (report.radiometry) {
      const formats::CameraRadiometry& g = report.radiometry->cameras.at(c);
      entry["gain"] = g.signal_per_radiance_second;
      entry["std"]["gain"] = OrNull(g.uncertainty.signal_per_radiance_second);
    }
    cameras.push_back(entry);
  }
  return cameras;
}

nlohmann::json RelativePoseEntries(const CalibrationReport& report) {
  nlohmann::json poses = nlohmann::json::array();
  for (const RelativePose& p : report.cameras.relative_poses) {
    poses.push_back({{"from", p.from},
                     {"to", p.to},
                     {"rotation_deg", Vector(p.rotation_deg)},
                     {"angle_deg", p.rotation_deg.norm()},
                     {"translation_mm", Vector(p.translation_mm)},
                     {"distance_mm", p.translation_mm.norm()},
                     {"std", p.has_std ? nlohmann::json{{"rotation_deg", Vector(p.rotation_std_deg)},
                                                        {"translation_mm", Vector(p.translation_std_mm)}}
                                       : nlohmann::json(nullptr)}});
  }
  return poses;
}

// One entry per lamp with what was calibrated of it: its position (from
// the mirror sphere) and its intensity (from the white reference).
nlohmann::json& LampEntry(nlohmann::json& lamps, std::size_t l, const std::string& id) {
  if (lamps.size() <= l) lamps.push_back({{"id", id}, {"std", nlohmann::json::object()}});
  return lamps[l];
}

nlohmann::json LightArcJson(const LightArcResult& a, nlohmann::json& lamps) {
  for (std::size_t l = 0; l < a.lamp_ids.size(); ++l) {
    nlohmann::json& entry = LampEntry(lamps, l, a.lamp_ids[l]);
    entry["position_mm"] = Vector(a.lamp_position[l]);
    entry["std"]["position_mm"] = Vector(a.lamp_position_sigma[l]);
  }
  nlohmann::json left_out = nlohmann::json::array();
  for (const LeftOutHighlight& h : a.left_out) left_out.push_back({{"file", h.name}, {"reason", h.reason}});
  const formats::LightArcCalibration::Uncertainty& u = a.light_arc.uncertainty;
  return {{"axis_point_mm", Vector(a.light_arc.axis_point_mm)},
          {"axis_direction", Vector(a.light_arc.axis_direction)},
          {"axis_estimated", a.axis_estimated},
          {"std",
           {{"axis_point_mm", u.axis_point_mm ? Vector(*u.axis_point_mm) : nlohmann::json(nullptr)},
            {"axis_direction", u.axis_direction ? Vector(*u.axis_direction) : nlohmann::json(nullptr)}}},
          {"highlights_used", a.highlights_used},
          {"highlights_left_out", left_out},
          {"ray_residual_rms_mm", a.ray_residual_rms_mm},
          {"sphere_centre_mm", Vector(a.sphere_centre_mm)},
          {"sphere_centre_std_mm", Vector(a.sphere_centre_sigma_mm)},
          {"written", a.too_uncertain.empty()},
          {"too_uncertain", a.too_uncertain},
          {"warnings", a.warnings}};
}

nlohmann::json RadiometryJson(const RadiometryResult& r, nlohmann::json& lamps) {
  for (std::size_t l = 0; l < r.lamp_ids.size(); ++l) {
    nlohmann::json& entry = LampEntry(lamps, l, r.lamp_ids[l]);
    entry["intensity"] = Vector(r.lamp_intensity[l]);
    entry["std"]["intensity"] = Vector(r.lamp_intensity_sigma[l]);
  }
  return {{"images_used", r.images_used},
          {"relative_residual_rms", r.relative_residual_rms},
          {"reduced_chi_square", r.reduced_chi_square}};
}

void AddLaserMounts(const CalibrationReport& report, nlohmann::json* json) {
  const LaserMountResult& f = *report.laser_mounts;
  nlohmann::json mounts = nlohmann::json::array();
  const auto sigma = [](const std::optional<Eigen::Vector3d>& v) { return v ? Vector(*v) : nlohmann::json(nullptr); };
  for (const formats::LaserMountCalibration& m : f.mounts) {
    mounts.push_back({{"id", m.id},
                      {"source_mm", Vector(m.source_mm)},
                      {"plane_normal_at_zero_tilt", Vector(m.plane_normal_at_zero_tilt)},
                      {"tilt_axis", Vector(m.tilt_axis)},
                      {"std",
                       {{"source_mm", sigma(m.uncertainty.source_mm)},
                        {"plane_normal_at_zero_tilt", sigma(m.uncertainty.plane_normal_at_zero_tilt)},
                        {"tilt_axis", sigma(m.uncertainty.tilt_axis)}}}});
  }
  (*json)["laser_mounts"] = mounts;
  nlohmann::json left_out = nlohmann::json::array();
  for (const SetAsideImage& i : report.laser_plates_left_out)
    left_out.push_back({{"file", i.name}, {"reason", i.reason}});
  (*json)["laser_mount_fit"] = {{"planes_used", f.planes_used},
                                {"plates_left_out", left_out},
                                {"position_residual_rms_mm", f.position_residual_rms_mm},
                                {"normal_residual_rms_deg", f.normal_residual_rms_deg},
                                {"written", f.too_uncertain.empty()},
                                {"too_uncertain", f.too_uncertain}};
}

}  // namespace

nlohmann::json ToJson(const CalibrationReport& report) {
  const nlohmann::json cameras = CameraEntries(report);
  const nlohmann::json poses = RelativePoseEntries(report);
  nlohmann::json json = {{"board", report.board},
                         {"cameras", cameras},
                         {"relative_poses", poses},
                         {"residual_sigma_px", report.cameras.residual_sigma_px},
                         {"warnings", report.cameras.warnings}};
  if (!report.cross_validation) json["cross_validation_skipped"] = report.cross_validation_skipped;
  if (!report.cameras.holder_poses.empty()) {
    // The world is the turntable's frame at angle 0: its axis is z through
    // the origin by construction; the holders are what was estimated.
    nlohmann::json holders = nlohmann::json::array();
    for (const core::RigidTransform& h : report.cameras.holder_poses) holders.push_back(core::ToJson(h));
    json["turntable"] = {{"axis_point_mm", {0, 0, 0}},
                         {"axis_direction", {0, 0, 1}},
                         {"frame",
                          "world: z along the axis, origin on the reference plane, x along the board "
                          "on the first holder tilt"},
                         {"holders", holders}};
  }
  nlohmann::json lamps = nlohmann::json::array();
  if (report.light_arc) json["light_arc"] = LightArcJson(*report.light_arc, lamps);
  if (report.radiometry) json["radiometry"] = RadiometryJson(*report.radiometry, lamps);
  if (!lamps.empty()) json["lamps"] = lamps;
  if (report.laser_mounts) AddLaserMounts(report, &json);
  // A rig's (it has a turntable): empty when every part came from images.
  if (!report.cameras.holder_poses.empty()) json["nominal_parts"] = report.nominal_parts;
  return json;
}

namespace {

// The first few of what a fit left out, with why; --json lists them all.
template <typename LeftOut>
void ListLeftOut(const std::vector<LeftOut>& left_out, const char* what, std::ostringstream& out) {
  constexpr std::size_t kListed = 6;
  for (std::size_t i = 0; i < left_out.size() && i < kListed; ++i) {
    out << "  left out " << left_out[i].name << ": " << left_out[i].reason << "\n";
  }
  if (left_out.size() > kListed) {
    out << "  ... and " << left_out.size() - kListed << " more " << what << " left out (--json lists them)\n";
  }
}

// The model a camera's distortion ladder chose, and the others' figures.
void FormatLadder(const CalibratedCamera& camera, std::ostringstream& out) {
  out << camera.calibration.id << " distortion: " << ToString(camera.distortion_model);
  if (camera.distortion_ladder.empty()) {
    out << " (as given)";
  } else {
    out << " (ladder:";
    for (const DistortionRung& rung : camera.distortion_ladder) {
      out << Line(" %s: rms %.3f px, AIC %.1f;", ToString(rung.model), rung.rms_px, rung.aic);
    }
    out.seekp(-1, std::ios_base::cur);
    out << ")";
  }
  const formats::Distortion& d = camera.calibration.distortion;
  const double values[5] = {d.k1, d.k2, d.p1, d.p2, d.k3};
  const char* names[5] = {"k1", "k2", "p1", "p2", "k3"};
  const std::optional<double> sigmas[5] = {d.uncertainty.k1, d.uncertainty.k2, d.uncertainty.p1, d.uncertainty.p2,
                                           d.uncertainty.k3};
  for (int i = 0; i < TermCount(camera.distortion_model); ++i) {
    const auto& u = camera.undetermined_terms;
    if (std::find(u.begin(), u.end(), names[i]) != u.end()) {
      out << Line(", %s undetermined (sigma %.3g)", names[i], sigmas[i].value_or(0.0));
    } else {
      out << Line(", %s %.5g", names[i], values[i]);
      if (sigmas[i]) out << Line(" +- %.2g", *sigmas[i]);
    }
  }
  out << "\n";
}

}  // namespace

std::string FormatCalibrationReport(const CalibrationReport& report) {
  std::ostringstream out;
  out << "board " << report.board << "; residual sigma " << Line("%.3f", report.cameras.residual_sigma_px) << " px\n";
  out << Line("%-12s %6s %7s %9s %18s %18s %18s %18s %9s %9s %10s %10s\n", "camera", "photos", "corners", "rms px",
              "fx px", "fy px", "cx px", "cy px", "k1", "k2", "proj px", "xval px");
  const auto with_std = [](double value, const std::optional<double>& std) {
    return std ? Line("%.2f +- %.2f", value, *std) : Line("%.2f", value);
  };
  // A term the model leaves out is 0 by construction; one whose sigma
  // exceeds it is not an estimate.
  const auto term = [](const CalibratedCamera& camera, int index, const char* name, double value) {
    if (index >= TermCount(camera.distortion_model)) return std::string("0 (fixed)");
    const auto& u = camera.undetermined_terms;
    if (std::find(u.begin(), u.end(), name) != u.end()) return std::string("undet.");
    return Line("%.4f", value);
  };
  for (std::size_t c = 0; c < report.cameras.cameras.size(); ++c) {
    const CalibratedCamera& camera = report.cameras.cameras[c];
    const formats::Intrinsics& k = camera.calibration.intrinsics;
    const std::string xval =
        report.cross_validation ? Line("%.3f", (*report.cross_validation)[c].rms_px) : std::string("-");
    const std::string projection = k.uncertainty.fx ? Line("%.3f", camera.projection_uncertainty_px) : "-";
    out << Line("%-12s %6d %7d %9.3f %18s %18s %18s %18s %9s %9s %10s %10s\n", camera.calibration.id.c_str(),
                camera.images_used, camera.corners_used, camera.rms_px, with_std(k.fx, k.uncertainty.fx).c_str(),
                with_std(k.fy, k.uncertainty.fy).c_str(), with_std(k.cx, k.uncertainty.cx).c_str(),
                with_std(k.cy, k.uncertainty.cy).c_str(),
                term(camera, 0, "k1", camera.calibration.distortion.k1).c_str(),
                term(camera, 1, "k2", camera.calibration.distortion.k2).c_str(), projection.c_str(), xval.c_str());
  }
  for (const CalibratedCamera& camera : report.cameras.cameras) FormatLadder(camera, out);
  for (const RelativePose& p : report.cameras.relative_poses) {
    if (!p.has_std) {
      out << Line("%s -> %s: rotation %.4f deg, translation %.3f %.3f %.3f mm\n", p.from.c_str(), p.to.c_str(),
                  p.rotation_deg.norm(), p.translation_mm.x(), p.translation_mm.y(), p.translation_mm.z());
      continue;
    }
    out << Line(
        "%s -> %s: rotation %.4f deg (std %.4f %.4f %.4f), translation %.3f %.3f %.3f mm (std %.3f %.3f %.3f)\n",
        p.from.c_str(), p.to.c_str(), p.rotation_deg.norm(), p.rotation_std_deg.x(), p.rotation_std_deg.y(),
        p.rotation_std_deg.z(), p.translation_mm.x(), p.translation_mm.y(), p.translation_mm.z(),
        p.translation_std_mm.x(), p.translation_std_mm.y(), p.translation_std_mm.z());
  }
  for (const CalibratedCamera& camera : report.cameras.cameras) {
    for (const SetAsideImage& image : camera.outlier_images) {
      out << "outlier photo " << camera.calibration.id << "/" << image.name << ": " << image.reason << "\n";
    }
  }
  if (report.radiometry) {
    const RadiometryResult& r = *report.radiometry;
    out << Line("radiometry from %d white reference images: residual %.4f relative RMS, reduced chi-square %.2f\n",
                r.images_used, r.relative_residual_rms, r.reduced_chi_square);
    for (std::size_t c = 0; c < r.cameras.size(); ++c) {
      const formats::CameraRadiometry& g = r.cameras[c];
      out << Line("  gain %-12s %.6g +- %.3g (%.3f %%)\n", report.cameras.cameras.at(c).calibration.id.c_str(),
                  g.signal_per_radiance_second, g.uncertainty.signal_per_radiance_second.value_or(0.0),
                  100 * g.uncertainty.signal_per_radiance_second.value_or(0.0) / g.signal_per_radiance_second);
    }
    for (std::size_t l = 0; l < r.lamp_ids.size(); ++l) {
      const Eigen::Vector3d& i = r.lamp_intensity[l];
      const Eigen::Vector3d& s = r.lamp_intensity_sigma[l];
      out << Line("  lamp %-12s intensity %.4f %.4f %.4f (std %.2g %.2g %.2g)\n", r.lamp_ids[l].c_str(), i.x(), i.y(),
                  i.z(), s.x(), s.y(), s.z());
    }
  }
  if (report.light_arc) {
    const LightArcResult& a = *report.light_arc;
    const Eigen::Vector3d& d = a.light_arc.axis_direction;
    const Eigen::Vector3d& q = a.light_arc.axis_point_mm;
    out << Line(
        "light arc from %d mirror sphere highlights (%zu left out): ray residual %.3f mm RMS; axis %s "
        "direction %.6f %.6f %.6f through %.3f %.3f %.3f mm\n",
        a.highlights_used, a.left_out.size(), a.ray_residual_rms_mm,
        a.axis_estimated ? "estimated," : "nominal (not estimated),", d.x(), d.y(), d.z(), q.x(), q.y(), q.z());
    if (a.light_arc.uncertainty.axis_direction) {
      const Eigen::Vector3d& sd = *a.light_arc.uncertainty.axis_direction;
      const Eigen::Vector3d& sq = *a.light_arc.uncertainty.axis_point_mm;
      out << Line("  axis std: direction %.2g %.2g %.2g, point %.3f %.3f %.3f mm\n", sd.x(), sd.y(), sd.z(), sq.x(),
                  sq.y(), sq.z());
    }
    for (std::size_t l = 0; l < a.lamp_ids.size(); ++l) {
      const Eigen::Vector3d& p = a.lamp_position[l];
      const Eigen::Vector3d& s = a.lamp_position_sigma[l];
      out << Line("  lamp %-12s position %.3f %.3f %.3f mm (std %.3f %.3f %.3f)\n", a.lamp_ids[l].c_str(), p.x(), p.y(),
                  p.z(), s.x(), s.y(), s.z());
    }
    out << Line("  sphere centre (sample frame) %.3f %.3f %.3f mm (std %.3f %.3f %.3f)\n", a.sphere_centre_mm.x(),
                a.sphere_centre_mm.y(), a.sphere_centre_mm.z(), a.sphere_centre_sigma_mm.x(),
                a.sphere_centre_sigma_mm.y(), a.sphere_centre_sigma_mm.z());
    ListLeftOut(a.left_out, "highlights", out);
    if (!a.too_uncertain.empty()) out << "  not written (nominal kept): " << a.too_uncertain << "\n";
    for (const std::string& w : a.warnings) out << "warning: " << w << "\n";
  }
  if (report.laser_mounts) {
    const LaserMountResult& f = *report.laser_mounts;
    out << Line("laser mounts from %d plate planes (%zu plate images left out): residual %.4f mm, %.4f degrees RMS\n",
                f.planes_used, report.laser_plates_left_out.size(), f.position_residual_rms_mm,
                f.normal_residual_rms_deg);
    for (const formats::LaserMountCalibration& m : f.mounts) {
      const Eigen::Vector3d& s = m.source_mm;
      const Eigen::Vector3d& a = m.tilt_axis;
      out << Line("  mount %-10s source %.2f %.2f %.2f mm, tilt axis %.5f %.5f %.5f", m.id.c_str(), s.x(), s.y(), s.z(),
                  a.x(), a.y(), a.z());
      if (m.uncertainty.source_mm && m.uncertainty.tilt_axis) {
        out << Line(" (std %.2f mm, %.3f degrees)", m.uncertainty.source_mm->maxCoeff(),
                    core::DegreesFromRadians(m.uncertainty.tilt_axis->maxCoeff()));
      }
      out << "\n";
    }
    ListLeftOut(report.laser_plates_left_out, "plate images", out);
    if (!f.too_uncertain.empty()) out << "  not written (nominal kept): " << f.too_uncertain << "\n";
  }
  if (!report.cross_validation) out << "cross-validation skipped: " << report.cross_validation_skipped << "\n";
  for (const std::string& warning : report.cameras.warnings) out << "warning: " << warning << "\n";
  if (!report.nominal_parts.empty()) {
    out << "not calibrated from images (the rig description's nominal values written): " << report.nominal_parts
        << "\n";
  }
  return out.str();
}

}  // namespace mesocap::calibration
