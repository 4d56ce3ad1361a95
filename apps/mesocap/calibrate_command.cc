// `mesocap calibrate camera --images DIR [--images DIR ...] --board SPEC
// --out calibration.json [--json]`: one camera, or several jointly, from
// folders of photos of a chessboard or ChArUco board
// (pipelines/calibrate_cameras.h); the report as a table or one JSON object.
#include <spdlog/spdlog.h>

#include <cstdio>

#include "apps/mesocap/command.h"
#include "pipelines/calibrate_cameras.h"

namespace mesocap {

void RegisterCalibrateCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::CalibrateCamerasOptions>();
  auto json = std::make_shared<bool>(false);
  CLI::App* group = GroupCommand(app, "calibrate", "Calibrate cameras (and, from a calibration session, the rig)");
  CLI::App* sub = group->add_subcommand(
      "camera", "Calibrate one camera, or several jointly with their relative poses, from folders of photos of a "
                "board (files with the same name in different folders were taken at the same instant)");
  sub->add_option("--images", o->image_folders, "folder of one camera's photos (JPEG, PNG, TIFF); repeat per camera")
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
  sub->callback([o, json] {
    const calibration::CalibrationReport report = pipelines::RunCalibrateCameras(*o);
    if (*json) {
      std::printf("%s\n", calibration::ToJson(report).dump(2).c_str());
    } else {
      std::printf("%s", calibration::FormatCalibrationReport(report).c_str());
    }
    spdlog::info("wrote {}", o->out.string());
  });
}

}  // namespace mesocap
