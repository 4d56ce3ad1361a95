#include "calibration/board_print.h"

#include <cmath>
#include <opencv2/aruco/dictionary.hpp>

namespace mesocap::calibration {

BoardPrint::BoardPrint(CalibrationBoard board) : board_(std::move(board)) {
  core::ThrowIfInvalid(board_.Check(), "board " + core::Quoted(board_.Spec()));
  if (board_.kind != CalibrationBoard::Kind::kCharuco) return;
  const cv::Ptr<cv::aruco::Dictionary> dictionary = cv::aruco::getPredefinedDictionary(
      static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(ArucoDictionaryId(board_.dictionary)));
  // OpenCV draws markers with a one-cell black border (borderBits = 1).
  marker_cells_ = dictionary->markerSize + 2;
  const int markers = (board_.cols * board_.rows) / 2;
  for (int id = 0; id < markers; ++id) {
    marker_bits_.push_back(
        cv::aruco::Dictionary::getBitsFromByteList(dictionary->bytesList.rowRange(id, id + 1), dictionary->markerSize));
  }
}

bool BoardPrint::Contains(double x_mm, double y_mm) const {
  const Eigen::Vector2d lo = board_.PrintedMin(), hi = board_.PrintedMax();
  return x_mm >= lo.x() && x_mm < hi.x() && y_mm >= lo.y() && y_mm < hi.y();
}

bool BoardPrint::IsWhite(double x_mm, double y_mm) const {
  if (!Contains(x_mm, y_mm)) return false;
  const double s = board_.square_mm;
  const int sx = static_cast<int>(std::floor(x_mm / s));
  const int sy = static_cast<int>(std::floor(y_mm / s));
  if (sx < 0 || sy < 0 || sx >= board_.SquaresX() || sy >= board_.SquaresY()) return true;  // the margin
  // Square (0, 0) is black on a ChArUco board (OpenCV's layout) and white on
  // a chessboard: OpenCV's chessboard detector numbers the corners of a board
  // with an odd and an even side from that end.
  if (board_.kind == CalibrationBoard::Kind::kChessboard) return (sx + sy) % 2 == 0;
  if ((sx + sy) % 2 == 0) return false;
  // White squares hold the markers in row-major order, each centred.
  const int marker = (sy * board_.SquaresX() + sx) / 2;
  const double offset = (s - board_.marker_mm) / 2;
  const double mx = x_mm - sx * s - offset, my = y_mm - sy * s - offset;
  if (mx < 0 || my < 0 || mx >= board_.marker_mm || my >= board_.marker_mm) return true;
  const double cell = board_.marker_mm / marker_cells_;
  const int cx = static_cast<int>(mx / cell), cy = static_cast<int>(my / cell);
  if (cx <= 0 || cy <= 0 || cx >= marker_cells_ - 1 || cy >= marker_cells_ - 1) return false;  // border
  return marker_bits_[static_cast<std::size_t>(marker)].at<unsigned char>(cy - 1, cx - 1) != 0;
}

}  // namespace mesocap::calibration
