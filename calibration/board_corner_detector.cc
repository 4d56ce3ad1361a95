#include "calibration/board_corner_detector.h"

#include <algorithm>
#include <cmath>
#include <opencv2/aruco/charuco.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace mesocap::calibration {
namespace {

cv::Mat LinearGray(const core::Image& image) {
  const core::Image mean = core::ChannelMean(image);
  cv::Mat gray(mean.height(), mean.width(), CV_32F);
  std::copy(mean.data(), mean.data() + mean.size(), gray.ptr<float>());
  return gray;
}

// The detectors take 8 bits: the linear image stretched so that its 99.5th
// percentile is white, which keeps a dim photo's board detectable.
cv::Mat EightBit(const cv::Mat& gray) {
  std::vector<float> values(gray.begin<float>(), gray.end<float>());
  const std::size_t k = static_cast<std::size_t>(0.995 * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  const double white = std::max(1e-6, static_cast<double>(values[k]));
  cv::Mat out;
  gray.convertTo(out, CV_8U, 255.0 / white);
  return out;
}

// The refinement window's half side, 2..10 px: cornerSubPix's gradients
// must come from the corner's own two edges, so the window stays short of
// the next corner and, on a ChArUco board, of the markers, which start
// (square - marker) / 2 from the corner.
int RefinementWindow(const CalibrationBoard& board, const std::vector<cv::Point2f>& corners) {
  double nearest = 1e9;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    for (std::size_t j = i + 1; j < corners.size(); ++j) nearest = std::min(nearest, cv::norm(corners[i] - corners[j]));
  }
  double reach = 0.4 * nearest;
  if (board.kind == CalibrationBoard::Kind::kCharuco) {
    reach = std::min(reach, 0.8 * nearest * (board.square_mm - board.marker_mm) / (2 * board.square_mm));
  }
  return std::clamp(static_cast<int>(reach), 2, 10);
}

double Bilinear(const cv::Mat& gray, double x, double y) {
  x = std::clamp(x, 0.0, gray.cols - 1.001);
  y = std::clamp(y, 0.0, gray.rows - 1.001);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const double fx = x - x0, fy = y - y0;
  return (1 - fy) * ((1 - fx) * gray.at<float>(y0, x0) + fx * gray.at<float>(y0, x0 + 1)) +
         fy * ((1 - fx) * gray.at<float>(y0 + 1, x0) + fx * gray.at<float>(y0 + 1, x0 + 1));
}

}  // namespace

BoardCornerDetector::BoardCornerDetector(CalibrationBoard board) : board_(std::move(board)) {
  core::ThrowIfInvalid(board_.Check(), "board " + core::Quoted(board_.Spec()));
}

BoardDetection BoardCornerDetector::Detect(const core::Image& image) const {
  const cv::Mat gray = LinearGray(image);
  const cv::Mat gray8 = EightBit(gray);
  std::vector<cv::Point2f> corners;
  std::vector<int> ids;
  if (board_.kind == CalibrationBoard::Kind::kChessboard) {
    const bool found = cv::findChessboardCornersSB(gray8, cv::Size(board_.cols, board_.rows), corners,
                                                   cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY);
    if (!found) return {};
    for (int i = 0; i < static_cast<int>(corners.size()); ++i) ids.push_back(i);
  } else {
    const cv::Ptr<cv::aruco::Dictionary> dictionary = cv::aruco::getPredefinedDictionary(
        static_cast<cv::aruco::PREDEFINED_DICTIONARY_NAME>(ArucoDictionaryId(board_.dictionary)));
    const cv::Ptr<cv::aruco::CharucoBoard> charuco =
        cv::aruco::CharucoBoard::create(board_.cols, board_.rows, static_cast<float>(board_.square_mm),
                                        static_cast<float>(board_.marker_mm), dictionary);
    std::vector<std::vector<cv::Point2f>> marker_corners;
    std::vector<int> marker_ids;
    cv::aruco::detectMarkers(gray8, dictionary, marker_corners, marker_ids);
    if (marker_ids.empty()) return {};
    cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray8, charuco, corners, ids);
    if (ids.empty()) return {};
  }
  if (corners.size() >= 2) {
    const int window = RefinementWindow(board_, corners);
    cv::cornerSubPix(gray, corners, cv::Size(window, window), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS | cv::TermCriteria::COUNT, 100, 1e-4));
  }
  BoardDetection detection;
  for (std::size_t i = 0; i < corners.size(); ++i) {
    detection.ids.push_back(ids[i]);
    detection.pixels.emplace_back(corners[i].x, corners[i].y);
  }
  return detection;
}

DetectionQuality BoardCornerDetector::Quality(const core::Image& image, const BoardDetection& detection) const {
  DetectionQuality quality;
  const cv::Mat gray = LinearGray(image);
  // Edges: the midpoints between corners that are neighbours along a row.
  const int per_row = board_.SquaresX() - 1;
  std::vector<double> widths;
  Eigen::Vector2d lo(1e30, 1e30), hi(-1e30, -1e30);
  for (std::size_t i = 0; i < detection.size(); ++i) {
    lo = lo.cwiseMin(detection.pixels[i]);
    hi = hi.cwiseMax(detection.pixels[i]);
    const int id = detection.ids[i];
    if ((id + 1) % per_row == 0) continue;
    const auto next = std::find(detection.ids.begin(), detection.ids.end(), id + 1);
    if (next == detection.ids.end()) continue;
    const Eigen::Vector2d a = detection.pixels[i];
    const Eigen::Vector2d b = detection.pixels[static_cast<std::size_t>(next - detection.ids.begin())];
    const double length = (b - a).norm();
    if (length < 6) continue;
    const Eigen::Vector2d mid = 0.5 * (a + b), normal = Eigen::Vector2d(a.y() - b.y(), b.x() - a.x()) / length;
    // Across the edge up to the nearest other ink: a ChArUco marker starts
    // (square - marker) / 2 into the white square.
    const double clear = board_.kind == CalibrationBoard::Kind::kCharuco
                             ? 0.9 * (board_.square_mm - board_.marker_mm) / (2 * board_.square_mm)
                             : 0.35;
    const double reach = clear * length, step = 0.25;
    std::vector<double> profile;
    for (double t = -reach; t <= reach; t += step) {
      profile.push_back(Bilinear(gray, mid.x() + t * normal.x(), mid.y() + t * normal.y()));
    }
    // Slopes over one pixel, so that a sharp edge (which a pixel's area
    // spreads over one pixel) measures about 1 px whatever its direction.
    double steepest = 0;
    for (std::size_t i = 4; i < profile.size(); ++i)
      steepest = std::max(steepest, std::abs(profile[i] - profile[i - 4]));
    const auto [lowest, highest] = std::minmax_element(profile.begin(), profile.end());
    const double contrast = *highest - *lowest;
    if (steepest > 0 && contrast > 0.05) widths.push_back(contrast / steepest);
  }
  if (widths.empty()) {
    quality.edge_width_px = std::nan("");
  } else {
    std::nth_element(widths.begin(), widths.begin() + static_cast<std::ptrdiff_t>(widths.size() / 2), widths.end());
    quality.edge_width_px = widths[widths.size() / 2];
  }
  if (!detection.empty()) {
    const int x0 = std::max(0, static_cast<int>(lo.x())), x1 = std::min(gray.cols - 1, static_cast<int>(hi.x()));
    const int y0 = std::max(0, static_cast<int>(lo.y())), y1 = std::min(gray.rows - 1, static_cast<int>(hi.y()));
    std::size_t saturated = 0, all = 0;
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        saturated += gray.at<float>(y, x) >= 0.999f;
        ++all;
      }
    }
    quality.saturated_fraction = all == 0 ? 0.0 : static_cast<double>(saturated) / static_cast<double>(all);
  }
  return quality;
}

}  // namespace mesocap::calibration
