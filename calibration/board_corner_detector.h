// Finds a calibration board's inner corners in a photo, to sub-pixel
// precision: OpenCV's chessboard detector (findChessboardCornersSB) or its
// ArUco marker detector with ChArUco corner interpolation (whose marker ids
// make partial views usable), then cv::cornerSubPix on the linear image.
// Pixel centres are at integer coordinates, as in OpenCV and the calibration file.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "calibration/calibration_board.h"
#include "core/image.h"

namespace mesocap::calibration {

// The corners found in one image: ids as CalibrationBoard numbers them, and
// their pixel positions. Empty when the board was not found.
struct BoardDetection {
  std::vector<int> ids;
  std::vector<Eigen::Vector2d> pixels;
  std::size_t size() const { return ids.size(); }
  bool empty() const { return ids.empty(); }
};

// How good the photo is where the board is, so a blurred or saturated view
// can be set aside with its reason.
struct DetectionQuality {
  // Median width of the squares' edges, black to white, in pixels (the
  // contrast over the steepest slope across each edge's midpoint): about 1
  // for a focused, antialiased edge. NaN when no two neighbouring corners
  // were found.
  double edge_width_px = 0;
  // Share of the pixels around the corners at the top of the range.
  double saturated_fraction = 0;
};

class BoardCornerDetector {
 public:
  explicit BoardCornerDetector(CalibrationBoard board);

  // `image`: linear values, full scale 1, any channel count (their mean is
  // used). Returns the detection (empty when the board is not found).
  BoardDetection Detect(const core::Image& image) const;
  DetectionQuality Quality(const core::Image& image, const BoardDetection& detection) const;

  const CalibrationBoard& board() const { return board_; }

 private:
  CalibrationBoard board_;
};

}  // namespace mesocap::calibration
