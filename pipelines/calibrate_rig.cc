#include "pipelines/calibrate_rig.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <map>

#include "calibration/board_corner_detector.h"
#include "calibration/cross_validation.h"
#include "calibration/laser_mount_calibration.h"
#include "calibration/light_arc_calibration.h"
#include "calibration/nominal_geometry.h"
#include "calibration/radiometric_calibration.h"
#include "calibration/sphere_highlight.h"
#include "core/atomic_file.h"
#include "core/image_io.h"
#include "formats/calibration.h"
#include "formats/capture_plan_steps.h"
#include "formats/captured_session.h"
#include "mdf/session_sweeps.h"

namespace mesocap::pipelines {

core::CheckResult CalibrateRigOptions::Check() const {
  if (session.empty()) return "--session: a calibration session folder is needed";
  if (out.empty()) return "--out: a calibration file to write is needed";
  if (!(light_arc.max_lamp_sigma_mm > 0)) return "--max-lamp-sigma-mm: expected a positive number of mm";
  if (!(laser_mounts.max_axis_sigma_deg > 0))
    return "--max-mount-axis-sigma-deg: expected a positive number of degrees";
  if (const core::CheckResult problem = laser_mounts.Check(); !problem.empty()) return problem;
  return calibration.Check();
}

namespace {

// The white reference's images of the session, one per (camera, lamp); none
// when the session has no white_reference steps.
std::vector<calibration::WhiteReferenceImage> ReadWhiteReferenceImages(const formats::CapturedSession& session,
                                                                       const formats::RigDescription& rig) {
  std::vector<calibration::WhiteReferenceImage> images;
  const auto& plan = session.manifest().plan;
  for (std::size_t s = 0; s < plan.size(); ++s) {
    if (plan[s].kind != formats::StepKind::kWhiteReference) continue;
    const formats::WhiteReferenceStep step = formats::ReadWhiteReferenceStep(plan[s], s, rig, session.manifest_file());
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      const core::ImageReadOptions read =
          formats::SessionFrameReadOptions(rig.cameras[c].width, rig.cameras[c].height, 3);
      calibration::WhiteReferenceImage image;
      image.camera = static_cast<int>(c);
      image.lamp = step.lamp;
      image.arc_rad = step.arc_rad;
      image.name = step.files.at(c).path;
      image.image = core::ReadImage(session.IntactFile(step.files.at(c).path), read);
      images.push_back(std::move(image));
    }
  }
  return images;
}

// The lamps' highlights in the session's mirror sphere images, one per
// (step, camera) that shows one; an image without a usable highlight is
// reported in `left_out`. None when the session has no mirror_sphere steps.
std::vector<calibration::HighlightObservation> FindMirrorSphereHighlights(
    const formats::CapturedSession& session, const formats::RigDescription& rig,
    std::vector<calibration::LeftOutHighlight>* left_out) {
  std::vector<calibration::HighlightObservation> seen;
  const auto& plan = session.manifest().plan;
  for (std::size_t s = 0; s < plan.size(); ++s) {
    if (plan[s].kind != formats::StepKind::kMirrorSphere) continue;
    const formats::MirrorSphereStep step = formats::ReadMirrorSphereStep(plan[s], s, rig, session.manifest_file());
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      const core::ImageReadOptions read =
          formats::SessionFrameReadOptions(rig.cameras[c].width, rig.cameras[c].height, 3);
      const std::string& name = step.files.at(c).path;
      const std::optional<calibration::SphereHighlight> highlight =
          calibration::FindSphereHighlight(core::ReadImage(session.IntactFile(name), read));
      if (!highlight) {
        left_out->push_back({name, "no highlight (the lamp's reflection is hidden or off the picture)"});
      } else if (!highlight->problem.empty()) {
        left_out->push_back({name, highlight->problem});
      } else {
        seen.push_back({static_cast<int>(c), step.lamp, step.turntable_rad, step.arc_rad, highlight->pixels, name});
      }
    }
  }
  return seen;
}

// The laser planes of the session's plates (laser_calibration steps), one
// per (location, tilt, camera) whose stripe is found on both plates; the
// others are reported in `left_out`. None when the session has no plates.
std::vector<calibration::LaserPlaneObservation> MeasureLaserPlates(const formats::CapturedSession& session,
                                                                   const formats::RigDescription& rig,
                                                                   const formats::Calibration& geometry,
                                                                   std::vector<calibration::SetAsideImage>* left_out) {
  // (location, tilt in nano-radians) -> its plates, lower first.
  std::map<std::pair<int, long long>, std::vector<formats::LaserCalibrationStep>> plates;
  const auto& plan = session.manifest().plan;
  for (std::size_t s = 0; s < plan.size(); ++s) {
    if (plan[s].kind != formats::StepKind::kLaserCalibration) continue;
    formats::LaserCalibrationStep step = formats::ReadLaserCalibrationStep(plan[s], s, rig, session.manifest_file());
    plates[{step.location, std::llround(step.tilt_rad * 1e9)}].push_back(std::move(step));
  }
  std::vector<calibration::LaserPlaneObservation> planes;
  if (plates.empty()) return planes;
  std::vector<calibration::CameraRays> rays;
  for (const formats::CameraCalibration& camera : geometry.cameras) rays.emplace_back(camera);
  // The stripe is searched as far out as process mdf searches its reference.
  const double outer_mm = mdf::SweepGeometryOptions().reference_extent * rig.sample_size_mm;
  for (auto& [key, steps] : plates) {
    if (steps.size() != 2) {
      throw core::FormatError(session.manifest_file(), "plan",
                              "two laser_calibration steps (two plate heights) for laser location " +
                                  std::to_string(key.first) + " at each tilt; found " + std::to_string(steps.size()));
    }
    std::sort(steps.begin(), steps.end(), [](const auto& a, const auto& b) { return a.height_mm < b.height_mm; });
    const formats::LaserCalibrationStep& lower = steps[0];
    const formats::LaserCalibrationStep& upper = steps[1];
    const Eigen::Vector2d scan =
        calibration::MountInWorld(geometry, lower.mount, lower.arc_rad, lower.tilt_rad).normal.head<2>().normalized();
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      const core::ImageReadOptions read =
          formats::SessionFrameReadOptions(rig.cameras[c].width, rig.cameras[c].height, 1);
      const std::string names = lower.files.at(c).path + " and " + upper.files.at(c).path;
      const core::Image low = core::ReadImage(session.IntactFile(lower.files.at(c).path), read);
      const core::Image high = core::ReadImage(session.IntactFile(upper.files.at(c).path), read);
      try {
        calibration::LaserPlaneObservation plane;
        plane.camera = static_cast<int>(c);
        plane.mount = lower.mount;
        plane.arc_rad = lower.arc_rad;
        plane.tilt_rad = lower.tilt_rad;
        plane.name = names;
        plane.fit = calibration::CalibrateLaserPlane(low, lower.height_mm, high, upper.height_mm, rays[c], scan,
                                                     outer_mm, {}, names);
        planes.push_back(std::move(plane));
      } catch (const core::FormatError&) {
        throw;
      } catch (const core::Error& e) {
        // The message starts with the names; the report gives them apart.
        std::string reason = e.what();
        if (reason.rfind(names + ": ", 0) == 0) reason.erase(0, names.size() + 2);
        left_out->push_back({names, reason});
      }
    }
  }
  return planes;
}

// The calibration board the session's rig description names.
calibration::CalibrationBoard ParseRigCalibrationBoard(const formats::RigDescription& rig,
                                                       const std::filesystem::path& manifest_file) {
  if (!rig.calibration_board) {
    throw core::FormatError(manifest_file, "rig.calibration_board", "missing: not a calibration session's rig");
  }
  return *calibration::RigCalibrationBoard(rig);
}

// One instant per board step, in plan order.
std::vector<formats::BoardImageStep> ReadBoardImageSteps(const formats::CapturedSession& session,
                                                         const formats::RigDescription& rig,
                                                         const std::filesystem::path& manifest_file,
                                                         const std::filesystem::path& session_folder) {
  std::vector<formats::BoardImageStep> steps;
  const auto& plan = session.manifest().plan;
  for (std::size_t s = 0; s < plan.size(); ++s) {
    if (plan[s].kind == formats::StepKind::kBoardImage) {
      steps.push_back(formats::ReadBoardImageStep(plan[s], s, rig, manifest_file));
    }
  }
  if (steps.empty()) {
    throw core::Error(session_folder.string() +
                      ": the session has no board images (record one with mesocap "
                      "simulate --plan calibration)");
  }
  return steps;
}

// The holder and turntable angle of each board step.
calibration::TurntableMotion BoardStepsTurntableMotion(const formats::RigDescription& rig,
                                                       const std::vector<formats::BoardImageStep>& steps) {
  calibration::TurntableMotion motion;
  motion.board_height_mm = rig.calibration_board->height_mm;
  motion.sample_size_mm = rig.sample_size_mm;
  for (const formats::BoardImageStep& step : steps) {
    motion.holder.push_back(step.holder);
    motion.angle_rad.push_back(step.turntable_rad);
  }
  return motion;
}

// Each camera's photos of the board steps, the board's corners found in them.
std::vector<calibration::CameraViews> DetectBoardInSessionPhotos(const formats::CapturedSession& session,
                                                                 const formats::RigDescription& rig,
                                                                 const calibration::CalibrationBoard& board,
                                                                 const std::vector<formats::BoardImageStep>& steps) {
  const calibration::BoardCornerDetector detector(board);
  std::vector<calibration::CameraViews> cameras;
  for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
    calibration::CameraViews views;
    views.id = rig.cameras[c].id;
    views.width = rig.cameras[c].width;
    views.height = rig.cameras[c].height;
    for (const formats::BoardImageStep& step : steps) views.names.push_back(step.files.at(c).path);
    const core::ImageReadOptions read = formats::SessionFrameReadOptions(views.width, views.height, 1);
    calibration::DetectBoardInPhotos(
        detector,
        [&](std::size_t i) -> std::optional<core::Image> {
          return core::ReadImage(session.IntactFile(steps[i].files.at(c).path), read);
        },
        &views);
    cameras.push_back(std::move(views));
  }
  return cameras;
}

// The cameras and the turntable from the board photos, cross-validated
// where asked.
calibration::CalibrationReport CalibrateCamerasAndTurntable(const calibration::CalibrationBoard& board,
                                                            const std::vector<calibration::CameraViews>& cameras,
                                                            const CalibrateRigOptions& options,
                                                            const calibration::TurntableMotion& motion) {
  calibration::CalibrationReport report;
  report.board = board.Spec();
  report.cameras = calibration::CalibrateCameras(board, cameras, options.calibration, &motion);
  if (options.cross_validate) {
    report.cross_validation = calibration::CrossValidate(board, cameras, options.calibration, report.cameras,
                                                         &report.cross_validation_skipped, &motion);
  } else {
    report.cross_validation_skipped = "not asked for";
  }
  return report;
}

// The light arc and the lamps' positions from the mirror sphere's
// highlights, into `out` where the session has them and their fit is
// certain enough; otherwise why they stay nominal, in `nominal_parts`.
void CalibrateLampsFromMirrorSphere(const formats::CapturedSession& session, const formats::RigDescription& rig,
                                    const CalibrateRigOptions& options, formats::Calibration* out,
                                    calibration::CalibrationReport* report, std::vector<std::string>* nominal_parts) {
  std::vector<calibration::LeftOutHighlight> left_out;
  const std::vector<calibration::HighlightObservation> highlights = FindMirrorSphereHighlights(session, rig, &left_out);
  if (!highlights.empty() || !left_out.empty()) {
    calibration::LightArcOptions arc = options.light_arc;
    arc.sphere_radius_mm = rig.mirror_sphere->radius_mm;
    arc.sphere_offset_mm = rig.mirror_sphere->offset_mm;
    arc.sphere_centre_height_mm = rig.mirror_sphere->centre_height_mm;
    report->light_arc = calibration::CalibrateLightArc(*out, highlights, arc);
    const calibration::LightArcResult& fit = *report->light_arc;
    report->light_arc->left_out.insert(report->light_arc->left_out.begin(), left_out.begin(), left_out.end());
    if (!fit.too_uncertain.empty()) {
      // A fit this uncertain would replace a rig built to its drawing with
      // a guess; the report gives it, the calibration keeps the drawing.
      nominal_parts->push_back(
          "light_arc, lamp positions (the mirror sphere's fit is too uncertain: " + fit.too_uncertain + ")");
    } else {
      if (fit.axis_estimated) out->light_arc = fit.light_arc;
      for (std::size_t l = 0; l < out->lamps.size(); ++l) {
        out->lamps[l].position_mm = fit.lamp_position[l];
        out->lamps[l].uncertainty.position_mm = fit.lamp_position_sigma[l];
      }
      if (!fit.axis_estimated) nominal_parts->push_back("light_arc (the lamps were imaged at one arc angle)");
    }
  } else {
    nominal_parts->push_back("light_arc, lamp positions (the session has no mirror sphere images)");
  }
}

// The laser mounts from the planes of the stripe on the plates, into `out`
// where the session has plates and their fit is certain enough; otherwise
// why they stay nominal, in `nominal_parts`.
void CalibrateLaserMountsFromPlates(const formats::CapturedSession& session, const formats::RigDescription& rig,
                                    const CalibrateRigOptions& options, formats::Calibration* out,
                                    calibration::CalibrationReport* report, std::vector<std::string>* nominal_parts) {
  const std::vector<calibration::LaserPlaneObservation> laser_planes =
      MeasureLaserPlates(session, rig, *out, &report->laser_plates_left_out);
  if (laser_planes.empty()) {
    nominal_parts->push_back("laser_mounts (the session has no laser plates" +
                             std::string(report->laser_plates_left_out.empty() ? ")" : " with a stripe found)"));
  } else {
    try {
      report->laser_mounts = calibration::CalibrateLaserMounts(*out, laser_planes, options.laser_mounts);
      report->laser_plates_left_out.insert(report->laser_plates_left_out.end(), report->laser_mounts->left_out.begin(),
                                           report->laser_mounts->left_out.end());
      if (report->laser_mounts->too_uncertain.empty()) {
        out->laser_mounts = report->laser_mounts->mounts;
      } else {
        nominal_parts->push_back("laser_mounts (their fit is too uncertain: " + report->laser_mounts->too_uncertain +
                                 ")");
      }
    } catch (const core::FormatError&) {
      throw;
    } catch (const core::Error& e) {
      // A mount without planes at two tilts leaves the rest of the rig's
      // calibration as good as it was: keep its drawing and say why.
      nominal_parts->push_back("laser_mounts (" + std::string(e.what()) + ")");
    }
  }
}

// The cameras' gains and the lamps' intensities from the white reference,
// into `out` where the session has one; otherwise why they stay nominal,
// in `nominal_parts`. Returns how many white reference images there were.
std::size_t CalibrateRadiometryFromWhiteReference(const formats::CapturedSession& session,
                                                  const formats::RigDescription& rig, formats::Calibration* out,
                                                  calibration::CalibrationReport* report,
                                                  std::vector<std::string>* nominal_parts) {
  std::vector<calibration::WhiteReferenceImage> white = ReadWhiteReferenceImages(session, rig);
  if (!white.empty()) {
    calibration::RadiometryOptions radiometry;
    radiometry.albedo = rig.white_reference->albedo;
    radiometry.height_mm = rig.white_reference->height_mm;
    radiometry.sample_size_mm = rig.sample_size_mm;
    std::vector<double> exposure_s;
    for (const formats::CameraDescription& camera : rig.cameras) exposure_s.push_back(camera.exposure_us * 1e-6);
    report->radiometry = calibration::CalibrateRadiometry(*out, exposure_s, white, radiometry);
    for (std::size_t c = 0; c < out->cameras.size(); ++c) out->cameras[c].radiometry = report->radiometry->cameras[c];
    for (std::size_t l = 0; l < out->lamps.size(); ++l) {
      out->lamps[l].intensity = report->radiometry->lamp_intensity[l];
      out->lamps[l].uncertainty.intensity = report->radiometry->lamp_intensity_sigma[l];
    }
  } else {
    nominal_parts->push_back("lamp intensities, camera radiometry (the session has no white reference)");
  }
  return white.size();
}

// What was calibrated from how many images, and what kept the rig
// description's nominal values.
void LogWhatWasCalibrated(const calibration::CalibrationReport& report, std::size_t board_images,
                          std::size_t white_images) {
  std::string from_images = "cameras and turntable from " + std::to_string(board_images) + " board images";
  if (report.light_arc && report.light_arc->too_uncertain.empty()) {
    from_images += ", lamp positions" + std::string(report.light_arc->axis_estimated ? " and the light arc" : "") +
                   " from " + std::to_string(report.light_arc->highlights_used) + " mirror sphere highlights";
  }
  if (report.laser_mounts && report.laser_mounts->too_uncertain.empty()) {
    from_images += ", laser mounts from " + std::to_string(report.laser_mounts->planes_used) + " plate planes";
  }
  if (white_images != 0) {
    from_images +=
        ", camera gains and lamp intensities from " + std::to_string(white_images) + " white reference images";
  }
  spdlog::info("calibrated {}{}", from_images,
               report.nominal_parts.empty()
                   ? std::string()
                   : "; " + report.nominal_parts + " are the rig description's nominal values");
}

}  // namespace

calibration::CalibrationReport RunCalibrateRig(const CalibrateRigOptions& options) {
  core::ThrowIfInvalid(options.Check(), "calibrate");
  core::RemoveStaleTemporariesOf(options.out);
  core::ExpectReplaceable(options.out,
                          {options.replace, "a calibration file", formats::IsCalibrationFile, {options.session}});
  formats::SessionOpenOptions open;
  open.command = "calibrate";
  const formats::CapturedSession session(options.session, open);
  const std::filesystem::path manifest_file = session.manifest_file();
  const formats::RigDescription rig = formats::ParseRigDescription(session.manifest().rig, manifest_file);
  const calibration::CalibrationBoard board = ParseRigCalibrationBoard(rig, manifest_file);
  const std::vector<formats::BoardImageStep> steps = ReadBoardImageSteps(session, rig, manifest_file, options.session);
  const calibration::TurntableMotion motion = BoardStepsTurntableMotion(rig, steps);
  const std::vector<calibration::CameraViews> cameras = DetectBoardInSessionPhotos(session, rig, board, steps);
  calibration::CalibrationReport report = CalibrateCamerasAndTurntable(board, cameras, options, motion);

  // Cameras and turntable from the photos; the rest nominal (see the header).
  formats::Calibration out = calibration::NominalCalibration(rig);
  for (std::size_t c = 0; c < cameras.size(); ++c) out.cameras[c] = report.cameras.cameras[c].calibration;
  std::vector<std::string> nominal_parts;
  CalibrateLampsFromMirrorSphere(session, rig, options, &out, &report, &nominal_parts);
  CalibrateLaserMountsFromPlates(session, rig, options, &out, &report, &nominal_parts);
  const std::size_t white_images = CalibrateRadiometryFromWhiteReference(session, rig, &out, &report, &nominal_parts);
  for (const std::string& part : nominal_parts) {
    report.nominal_parts += (report.nominal_parts.empty() ? "" : ", ") + part;
  }
  formats::WriteCalibration(options.out, out);
  LogWhatWasCalibrated(report, steps.size() * rig.cameras.size(), white_images);
  return report;
}

}  // namespace mesocap::pipelines
