// `mesocap calibrate --session S --out calibration.json [--json]`: a rig from
// its calibration session (pipelines/calibrate_rig.h); and `mesocap
// calibrate camera --images DIR [--images DIR ...] --board SPEC --out
// calibration.json [--json]`: one camera, or several jointly, from folders
// of photos of a chessboard or ChArUco board (pipelines/calibrate_cameras.h).
// The report prints as a table or one JSON object.
#include <spdlog/spdlog.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "pipelines/calibrate_cameras.h"
#include "pipelines/calibrate_rig.h"

namespace mesocap {

namespace {

void PrintReport(const calibration::CalibrationReport& report, bool json) {
  if (json) {
    std::printf("%s\n", calibration::ToJson(report).dump(2).c_str());
  } else {
    std::printf("%s", calibration::FormatCalibrationReport(report).c_str());
  }
}

// --distortion: the ladder's choice (auto) or one model for every camera.
void AddDistortionOption(CLI::App* command, std::vector<calibration::DistortionModel>* models,
                         const std::string& default_name) {
  command
      ->add_option_function<std::string>(
          "--distortion",
          [models](const std::string& name) {
            using calibration::DistortionModel;
            const std::map<std::string, DistortionModel> by_name = {{"none", DistortionModel::kNone},
                                                                    {"k1", DistortionModel::kK1},
                                                                    {"k1k2", DistortionModel::kK1K2},
                                                                    {"full", DistortionModel::kFull}};
            models->clear();
            if (name != "auto") models->push_back(by_name.at(name));
          },
          "distortion terms to estimate: auto (each camera the fewest its photos determine, from none, k1, k1 k2 "
          "and k1 k2 p1 p2 k3; the rule in docs/FORMATS.md, \"Calibration report\"), or none, k1, k1k2, full for "
          "every camera; terms left out are written as 0")
      ->check(CLI::IsMember({"auto", "none", "k1", "k1k2", "full"}))
      ->default_str(default_name);
}

}  // namespace

void RegisterCalibrateCommand(CLI::App& app) {
  auto rig = std::make_shared<pipelines::CalibrateRigOptions>();
  auto rig_json = std::make_shared<bool>(false);
  CLI::App* group = app.add_subcommand("calibrate", HelpText("calibrate"));
  group->require_subcommand(0, 1);
  group->add_option("--session", rig->session, "calibration session (mesocap simulate --plan calibration)");
  group->add_option("--out", rig->out, "calibration file to write");
  group->add_flag("--json", *rig_json, "print the report as one JSON object");
  group->add_flag("--replace", rig->replace, "replace an existing file at --out");
  group->add_option("--max-lamp-sigma-mm", rig->light_arc.max_lamp_sigma_mm,
                    "keep the rig description's lamps and light arc when the mirror sphere's fit leaves any lamp "
                    "(or the arc's axis point) more uncertain than this, mm at one sigma (default 5)");
  group->add_option("--max-mount-axis-sigma-deg", rig->laser_mounts.max_axis_sigma_deg,
                    "keep the rig description's laser mounts when the plates' fit leaves any mount's tilt axis more "
                    "uncertain than this, degrees at one sigma (default 1)");
  AddDistortionOption(group, &rig->calibration.distortion_models, "full");
  group->callback([group, rig, rig_json] {
    if (!group->get_subcommands().empty()) return;
    if (rig->session.empty() || rig->out.empty()) {
      throw CLI::ValidationError("calibrate", "give --session SESSION --out FILE, or the camera subcommand");
    }
    PrintReport(pipelines::RunCalibrateRig(*rig), *rig_json);
    spdlog::info("wrote {}", rig->out.string());
  });

  auto o = std::make_shared<pipelines::CalibrateCamerasOptions>();
  auto json = std::make_shared<bool>(false);
  CLI::App* sub = group->add_subcommand("camera", HelpText("calibrate_camera"));
  sub->add_option("--images", o->image_folders,
                  "folder of one camera's photos, all of one size: .jpg/.jpeg (baseline or progressive), .png, "
                  ".tif/.tiff, 8 or 16 bits, grey or colour, turned upright as their EXIF orientation says; repeat "
                  "per camera")
      ->required();
  sub->add_option("--board", o->board,
                  "the board: chessboard:COLSxROWS:SQUARE_MM (inner corners) or "
                  "charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICTIONARY (squares; e.g. DICT_5X5_100)")
      ->required();
  sub->add_option("--out", o->out, "calibration file to write (world frame: the first camera's)")->required();
  sub->add_flag("--json", *json, "print the report as one JSON object");
  sub->add_flag("--replace", o->replace, "replace an existing file at --out");
  sub->add_option("--max-rms-px", o->calibration.max_rms_px,
                  "refuse the board when the photos' reprojection RMS exceeds this")
      ->check(InRange(1e-3, 100))
      ->capture_default_str();
  AddDistortionOption(sub, &o->calibration.distortion_models, "auto");
  sub->callback([o, json] {
    PrintReport(pipelines::RunCalibrateCameras(*o), *json);
    spdlog::info("wrote {}", o->out.string());
  });
}

}  // namespace mesocap
