// A planar calibration target: a plain chessboard or a ChArUco board
// (OpenCV's aruco module), its corners in the board frame and its printed
// pattern, so that photos of it can be detected and, in the simulator,
// rendered.
//
// Board frame: x along the columns, y along the rows (down the printed
// page), z = x cross y into the page; the origin is the outer corner of the
// first square (OpenCV's ChArUco convention), lengths in mm.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/error.h"
#include "formats/rig_description.h"

namespace mesocap::calibration {

struct CalibrationBoard {
  enum class Kind { kChessboard, kCharuco };
  Kind kind = Kind::kCharuco;
  // Chessboard: inner corners per row and per column (OpenCV's patternSize).
  // ChArUco: squares per row and per column (OpenCV's squaresX, squaresY).
  int cols = 0, rows = 0;
  double square_mm = 0;
  double marker_mm = 0;    // ChArUco only: a marker's side
  std::string dictionary;  // ChArUco only: OpenCV's name, e.g. "DICT_5X5_100"

  // Empty when the board can be printed and detected: at least 2 x 2 inner
  // corners (3 x 3 squares for ChArUco), positive sizes, markers smaller than
  // squares, a known dictionary with a marker for every white square.
  core::CheckResult Check() const;

  // Squares along x and y, the white margin around them included (one square
  // on each side for a chessboard, which its detector needs; none for
  // ChArUco, whose markers carry the ids).
  int SquaresX() const;
  int SquaresY() const;
  // Inner corners: their count, and the position of corner `id` (ids run
  // along x first, as OpenCV numbers both boards' corners) in the board frame.
  int CornerCount() const;
  Eigen::Vector3d CornerPosition(int id) const;
  // The printed area, margin included, in mm: [0, width] x [0, height] of the
  // board frame (a chessboard's margin lies at negative coordinates too).
  Eigen::Vector2d PrintedMin() const;
  Eigen::Vector2d PrintedMax() const;
  // The spec's text, as ParseBoardSpec reads it.
  std::string Spec() const;
};

// "chessboard:COLSxROWS:SQUARE_MM" (inner corners) or
// "charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICTIONARY" (squares; DICTIONARY as
// OpenCV names it, DICT_ optional, any case). Throws Error saying which part
// of `spec` is wrong and what was expected.
CalibrationBoard ParseBoardSpec(std::string_view spec);

// The board a rig description names (ParseBoardSpec of its
// calibration_board.board), nullopt when it names none. FormatError naming
// rig.file and the field when the spec is not a board.
std::optional<CalibrationBoard> RigCalibrationBoard(const formats::RigDescription& rig);

// OpenCV's predefined dictionary id for a name such as "DICT_5X5_100" or
// "5x5_100"; -1 when there is none.
int ArucoDictionaryId(std::string_view name);

}  // namespace mesocap::calibration
