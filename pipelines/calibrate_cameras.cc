#include "pipelines/calibrate_cameras.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <map>
#include <set>

#include "calibration/board_corner_detector.h"
#include "calibration/cross_validation.h"
#include "core/atomic_file.h"
#include "core/image_io.h"
#include "formats/calibration.h"

namespace mesocap::pipelines {
namespace {

bool IsPhoto(const std::filesystem::path& file) {
  std::string extension = file.extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return extension == ".jpg" || extension == ".jpeg" || extension == ".png" || extension == ".tif" ||
         extension == ".tiff";
}

// A camera's id from its folder's name, where that is a valid id.
std::string CameraId(const std::filesystem::path& folder, std::size_t index, std::set<std::string>* taken) {
  std::string id = std::filesystem::path(folder).lexically_normal().filename().string();
  if (id.empty()) id = std::filesystem::path(folder).lexically_normal().parent_path().filename().string();
  if (!formats::IsValidId(id) || taken->count(id)) id = "camera" + std::to_string(index);
  taken->insert(id);
  return id;
}

}  // namespace

core::CheckResult CalibrateCamerasOptions::Check() const {
  if (image_folders.empty()) return "--images: at least one folder of photos is needed";
  if (out.empty()) return "--out: a calibration file to write is needed";
  return calibration.Check();
}

std::vector<std::filesystem::path> PhotosIn(const std::filesystem::path& folder) {
  std::error_code error;
  if (!std::filesystem::is_directory(folder, error)) {
    throw core::Error("--images " + core::Quoted(folder.string()) + ": not a folder");
  }
  std::vector<std::filesystem::path> photos;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    if (entry.is_regular_file() && IsPhoto(entry.path())) photos.push_back(entry.path());
  }
  if (photos.empty()) {
    throw core::Error("--images " + core::Quoted(folder.string()) + ": the folder holds no JPEG, PNG or TIFF photo");
  }
  std::sort(photos.begin(), photos.end());
  return photos;
}

calibration::CalibrationReport RunCalibrateCameras(const CalibrateCamerasOptions& options) {
  core::ThrowIfInvalid(options.Check(), "calibrate camera");
  const calibration::CalibrationBoard board = calibration::ParseBoardSpec(options.board);
  if (options.image_folders.size() > 1 && board.kind == calibration::CalibrationBoard::Kind::kChessboard &&
      board.cols % 2 == board.rows % 2) {
    throw core::Error("board " + core::Quoted(options.board) +
                      ": a chessboard whose inner corners are both even or both odd looks the same turned by 180 "
                      "degrees, so its corners cannot be matched between cameras; use one with an odd and an even "
                      "side, or a ChArUco board");
  }
  {
    std::vector<std::filesystem::path> inputs(options.image_folders.begin(), options.image_folders.end());
    core::RemoveStaleTemporariesOf(options.out);
    core::ExpectReplaceable(options.out, {options.replace, "a calibration file", formats::IsCalibrationFile, inputs});
  }

  // The instants: every photo name in any folder.
  std::vector<std::vector<std::filesystem::path>> photos;
  std::set<std::string> names;
  for (const std::filesystem::path& folder : options.image_folders) {
    photos.push_back(PhotosIn(folder));
    for (const auto& p : photos.back()) names.insert(p.filename().string());
  }
  const std::vector<std::string> instants(names.begin(), names.end());

  std::vector<calibration::CameraViews> cameras;
  std::set<std::string> taken;
  const calibration::BoardCornerDetector detector(board);
  for (std::size_t c = 0; c < photos.size(); ++c) {
    calibration::CameraViews views;
    views.id = CameraId(options.image_folders[c], c, &taken);
    views.names = instants;
    // Every photo of a camera has the first one's size.
    const core::ImageHeader first = core::ReadImageHeader(photos[c].front());
    views.width = first.width;
    views.height = first.height;
    std::map<std::string, std::filesystem::path> by_name;
    for (const auto& p : photos[c]) {
      const core::ImageHeader header = core::ReadImageHeader(p);
      if (header.width != first.width || header.height != first.height) {
        throw core::FormatError(p, "size",
                                std::to_string(header.width) + "x" + std::to_string(header.height) +
                                    " differs from the folder's first photo " +
                                    core::Quoted(photos[c].front().filename().string()) + " (" +
                                    std::to_string(first.width) + "x" + std::to_string(first.height) +
                                    "); one folder holds one camera's photos");
      }
      by_name[p.filename().string()] = p;
    }
    calibration::DetectBoardInPhotos(
        detector,
        [&](std::size_t i) -> std::optional<core::Image> {
          const auto found = by_name.find(instants[i]);
          if (found == by_name.end()) return std::nullopt;
          return core::ReadImage(found->second);
        },
        &views);
    spdlog::info("camera {}: the board found in {} of {} photos", views.id,
                 std::count_if(views.detections.begin(), views.detections.end(),
                               [](const calibration::BoardDetection& d) { return !d.empty(); }),
                 photos[c].size());
    cameras.push_back(std::move(views));
  }

  calibration::CalibrationReport report;
  report.board = board.Spec();
  report.cameras = calibration::CalibrateCameras(board, cameras, options.calibration);
  if (options.cross_validate) {
    report.cross_validation = calibration::CrossValidate(board, cameras, options.calibration, report.cameras,
                                                         &report.cross_validation_skipped);
  } else {
    report.cross_validation_skipped = "not asked for";
  }

  // A camera-only calibration: no turntable or light arc was observed, so
  // those keep the format's neutral values (sample at the turntable's origin).
  formats::Calibration calibration;
  calibration.turntable.sample_pose.transform.parent_frame = "turntable";
  calibration.turntable.sample_pose.transform.child_frame = "sample";
  for (const calibration::CalibratedCamera& camera : report.cameras.cameras) {
    calibration.cameras.push_back(camera.calibration);
  }
  formats::WriteCalibration(options.out, calibration);
  return report;
}

}  // namespace mesocap::pipelines
