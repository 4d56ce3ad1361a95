// `mesocap calibrate camera`: one camera, or several jointly with their
// relative poses, from folders of photos of a calibration board (one folder
// per camera; across folders, files with the same name were taken at the
// same instant). Writes a calibration (formats/calibration.h) whose world
// frame is the first camera's, and returns the report.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "calibration/calibration_report.h"
#include "calibration/camera_calibration.h"
#include "core/error.h"

namespace mesocap::pipelines {

struct CalibrateCamerasOptions {
  std::vector<std::filesystem::path> image_folders;  // one per camera
  std::string board;                                 // a board spec (calibration/calibration_board.h)
  std::filesystem::path out;                         // calibration.json to write
  bool replace = false;
  bool cross_validate = true;
  calibration::CameraCalibrationOptions calibration;
  core::CheckResult Check() const;
};

// Every check (folders, photos, board) happens before anything is written;
// on any error nothing is.
calibration::CalibrationReport RunCalibrateCameras(const CalibrateCamerasOptions& options);

// The photos a folder holds: JPEG, PNG and TIFF files (by extension, any
// case), sorted by name. Throws Error naming the folder when it holds none.
std::vector<std::filesystem::path> PhotosIn(const std::filesystem::path& folder);

}  // namespace mesocap::pipelines
