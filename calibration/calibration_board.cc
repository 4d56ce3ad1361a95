#include "calibration/calibration_board.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <opencv2/aruco/dictionary.hpp>
#include <sstream>

namespace mesocap::calibration {
namespace {

std::vector<std::string_view> SplitColons(std::string_view text) {
  std::vector<std::string_view> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t colon = text.find(':', start);
    parts.push_back(text.substr(start, colon == std::string_view::npos ? std::string_view::npos : colon - start));
    if (colon == std::string_view::npos) return parts;
    start = colon + 1;
  }
}

int ParseCount(std::string_view text, std::string_view spec, std::string_view what) {
  int value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || value < 1 || value > 1000) {
    throw core::Error("board " + core::Quoted(spec) + ": " + std::string(what) + " " + core::Quoted(text) +
                      " is not a whole number in 1..1000");
  }
  return value;
}

double ParseLength(std::string_view text, std::string_view spec, std::string_view what) {
  double value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (error != std::errc() || end != text.data() + text.size() || !(value > 0 && value <= 10000)) {
    throw core::Error("board " + core::Quoted(spec) + ": " + std::string(what) + " " + core::Quoted(text) +
                      " is not a length in mm in (0, 10000]");
  }
  return value;
}

struct NamedDictionary {
  const char* name;
  int id;
};
constexpr std::array kDictionaries = {
    NamedDictionary{"DICT_4X4_50", cv::aruco::DICT_4X4_50},
    NamedDictionary{"DICT_4X4_100", cv::aruco::DICT_4X4_100},
    NamedDictionary{"DICT_4X4_250", cv::aruco::DICT_4X4_250},
    NamedDictionary{"DICT_4X4_1000", cv::aruco::DICT_4X4_1000},
    NamedDictionary{"DICT_5X5_50", cv::aruco::DICT_5X5_50},
    NamedDictionary{"DICT_5X5_100", cv::aruco::DICT_5X5_100},
    NamedDictionary{"DICT_5X5_250", cv::aruco::DICT_5X5_250},
    NamedDictionary{"DICT_5X5_1000", cv::aruco::DICT_5X5_1000},
    NamedDictionary{"DICT_6X6_50", cv::aruco::DICT_6X6_50},
    NamedDictionary{"DICT_6X6_100", cv::aruco::DICT_6X6_100},
    NamedDictionary{"DICT_6X6_250", cv::aruco::DICT_6X6_250},
    NamedDictionary{"DICT_6X6_1000", cv::aruco::DICT_6X6_1000},
    NamedDictionary{"DICT_7X7_50", cv::aruco::DICT_7X7_50},
    NamedDictionary{"DICT_7X7_100", cv::aruco::DICT_7X7_100},
    NamedDictionary{"DICT_7X7_250", cv::aruco::DICT_7X7_250},
    NamedDictionary{"DICT_7X7_1000", cv::aruco::DICT_7X7_1000},
    NamedDictionary{"DICT_ARUCO_ORIGINAL", cv::aruco::DICT_ARUCO_ORIGINAL},
};

int DictionarySize(int id) {
  return cv::aruco::getPredefinedDictionary(static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(id))->bytesList.rows;
}

}  // namespace

int ArucoDictionaryId(std::string_view name) {
  std::string upper;
  for (const char c : name) upper.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(c))));
  if (upper.rfind("DICT_", 0) != 0) upper = "DICT_" + upper;
  for (const NamedDictionary& d : kDictionaries) {
    if (upper == d.name) return d.id;
  }
  return -1;
}

core::CheckResult CalibrationBoard::Check() const {
  const int min_side = kind == Kind::kChessboard ? 2 : 3;
  if (cols < min_side || rows < min_side) {
    std::ostringstream message;
    message << (kind == Kind::kChessboard ? "inner corners " : "squares ") << cols << "x" << rows
            << ": expected at least " << min_side << "x" << min_side;
    return message.str();
  }
  if (!(square_mm > 0)) return "square size must be positive";
  if (kind == Kind::kChessboard) return {};
  if (!(marker_mm > 0 && marker_mm < square_mm)) return "marker size must be positive and smaller than the square";
  const int id = ArucoDictionaryId(dictionary);
  if (id < 0) return "unknown ArUco dictionary " + core::Quoted(dictionary) + " (expected e.g. DICT_5X5_100)";
  const int markers = (cols * rows) / 2;
  if (markers > DictionarySize(id)) {
    return "dictionary " + core::Quoted(dictionary) + " has " + std::to_string(DictionarySize(id)) +
           " markers, the board needs " + std::to_string(markers);
  }
  return {};
}

int CalibrationBoard::SquaresX() const { return kind == Kind::kChessboard ? cols + 1 : cols; }
int CalibrationBoard::SquaresY() const { return kind == Kind::kChessboard ? rows + 1 : rows; }

int CalibrationBoard::CornerCount() const { return (SquaresX() - 1) * (SquaresY() - 1); }

Eigen::Vector3d CalibrationBoard::CornerPosition(int id) const {
  const int per_row = SquaresX() - 1;
  return Eigen::Vector3d((id % per_row + 1) * square_mm, (id / per_row + 1) * square_mm, 0.0);
}

Eigen::Vector2d CalibrationBoard::PrintedMin() const {
  const double margin = kind == Kind::kChessboard ? square_mm : 0.0;
  return Eigen::Vector2d(-margin, -margin);
}

Eigen::Vector2d CalibrationBoard::PrintedMax() const {
  const double margin = kind == Kind::kChessboard ? square_mm : 0.0;
  return Eigen::Vector2d(SquaresX() * square_mm + margin, SquaresY() * square_mm + margin);
}

std::string CalibrationBoard::Spec() const {
  std::ostringstream spec;
  spec << (kind == Kind::kChessboard ? "chessboard:" : "charuco:") << cols << "x" << rows << ":" << square_mm;
  if (kind == Kind::kCharuco) spec << ":" << marker_mm << ":" << dictionary;
  return spec.str();
}

CalibrationBoard ParseBoardSpec(std::string_view spec) {
  const std::vector<std::string_view> parts = SplitColons(spec);
  CalibrationBoard board;
  if (parts[0] == "chessboard" && parts.size() == 3) {
    board.kind = CalibrationBoard::Kind::kChessboard;
  } else if (parts[0] == "charuco" && parts.size() == 5) {
    board.kind = CalibrationBoard::Kind::kCharuco;
  } else {
    throw core::Error("board " + core::Quoted(spec) +
                      ": expected chessboard:COLSxROWS:SQUARE_MM or "
                      "charuco:COLSxROWS:SQUARE_MM:MARKER_MM:DICTIONARY");
  }
  const std::size_t x = parts[1].find_first_of("xX");
  if (x == std::string_view::npos) {
    throw core::Error("board " + core::Quoted(spec) + ": size " + core::Quoted(parts[1]) + " is not COLSxROWS");
  }
  board.cols = ParseCount(parts[1].substr(0, x), spec, "COLS");
  board.rows = ParseCount(parts[1].substr(x + 1), spec, "ROWS");
  board.square_mm = ParseLength(parts[2], spec, "SQUARE_MM");
  if (board.kind == CalibrationBoard::Kind::kCharuco) {
    board.marker_mm = ParseLength(parts[3], spec, "MARKER_MM");
    const int id = ArucoDictionaryId(parts[4]);
    board.dictionary = id < 0 ? std::string(parts[4]) : std::string(kDictionaries[0].name);
    for (const NamedDictionary& d : kDictionaries) {
      if (d.id == id) board.dictionary = d.name;
    }
  }
  core::ThrowIfInvalid(board.Check(), "board " + core::Quoted(spec));
  return board;
}

std::optional<CalibrationBoard> RigCalibrationBoard(const formats::RigDescription& rig) {
  if (!rig.calibration_board) return std::nullopt;
  try {
    return ParseBoardSpec(rig.calibration_board->board);
  } catch (const core::Error& e) {
    throw core::FormatError(rig.file, "calibration_board.board", e.what());
  }
}

}  // namespace mesocap::calibration
