// What a calibration board looks like printed: white paper with black
// squares and, on a ChArUco board, the ArUco markers of OpenCV's dictionary
// in the white squares. The simulator renders photos of boards from it, with
// edges exact at any magnification.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "calibration/calibration_board.h"

namespace mesocap::calibration {

class BoardPrint {
 public:
  // Throws Error when the board does not pass its Check().
  explicit BoardPrint(CalibrationBoard board);

  const CalibrationBoard& board() const { return board_; }
  // True where the print is white at board point (x, y) mm; false on black
  // ink and outside the printed area (PrintedMin..PrintedMax).
  bool IsWhite(double x_mm, double y_mm) const;
  bool Contains(double x_mm, double y_mm) const;

 private:
  CalibrationBoard board_;
  int marker_cells_ = 0;              // cells per marker side, its black border included
  std::vector<cv::Mat> marker_bits_;  // per white square in OpenCV's order: 1 = white cell
};

}  // namespace mesocap::calibration
