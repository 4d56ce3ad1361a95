#include "calibration/laser_line.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <string>

namespace mesocap::calibration {

core::CheckResult LaserLineOptions::Check() const {
  if (!(gaussian_sigma_px >= 0 && gaussian_sigma_px <= 20)) return "gaussian_sigma_px must be in [0, 20]";
  if (!(min_peak > 0 && min_peak < 1)) return "min_peak must be in (0, 1)";
  if (min_candidates < 2) return "min_candidates must be at least 2";
  if (!(min_inlier_tolerance_mm > 0)) return "min_inlier_tolerance_mm must be positive";
  return {};
}

double InterpolatePeak(double t0, double y0, double t1, double y1, double t2, double y2) {
  if (y0 > 0 && y1 > 0 && y2 > 0) {
    y0 = std::log(y0);
    y1 = std::log(y1);
    y2 = std::log(y2);
  }
  // f(t) = a (t - t1)^2 + b (t - t1) + y1 through the three samples.
  const double h0 = t1 - t0, h1 = t2 - t1;
  const double d0 = y0 - y1, d2 = y2 - y1;
  const double a = (d0 * h1 + d2 * h0) / (h0 * h1 * (h0 + h1));
  if (!(a < 0)) return t1;  // flat or not a maximum: no refinement
  const double b = (d2 - a * h1 * h1) / h1;
  return std::clamp(t1 - b / (2 * a), t1 - 0.5 * h0, t1 + 0.5 * h1);
}

namespace {

// Least-squares (L2) or Huber line through points: (point, unit direction).
void FitLine(const std::vector<cv::Point2f>& points, int distance, Eigen::Vector2d* point, Eigen::Vector2d* dir) {
  cv::Vec4f line;
  cv::fitLine(points, line, distance, 0, 0.001, 0.001);
  *dir = Eigen::Vector2d(line[0], line[1]).normalized();
  *point = Eigen::Vector2d(line[2], line[3]);
}

// How many scanlines one independent sample spans after a Gaussian
// pre-filter of sigma s: white noise filtered so correlates at lag k as
// exp(-k^2 / 4 s^2), and the variance of a mean grows by the sum over lags.
double CorrelatedScanlines(double sigma_px) {
  if (sigma_px <= 0) return 1.0;
  double sum = 1.0;
  for (int k = 1; k < 64; ++k) sum += 2.0 * std::exp(-k * k / (4.0 * sigma_px * sigma_px));
  return sum;
}

}  // namespace

ReferenceLine DetectLaserLine(const core::Image& frame, const PixelMask& mask, const CameraRays& rays, double height,
                              const Eigen::Vector2d& scan_direction, const LaserLineOptions& options) {
  const int w = frame.width(), h = frame.height();
  if (frame.channels() != 1 || w != rays.width() || h != rays.height() ||
      mask.size() != static_cast<std::size_t>(w) * h) {
    throw core::Error("laser line: frame is " + std::to_string(w) + "x" + std::to_string(h) + "x" +
                      std::to_string(frame.channels()) + ", expected 1 channel of the camera's " +
                      std::to_string(rays.width()) + "x" + std::to_string(rays.height()) + " with a mask of that size");
  }
  cv::Mat image(h, w, CV_32F, const_cast<float*>(frame.data()));
  cv::Mat blurred;
  if (options.gaussian_sigma_px > 0) {
    cv::GaussianBlur(image, blurred, cv::Size(0, 0), options.gaussian_sigma_px);
  } else {
    blurred = image;
  }
  // Scanlines run along the image of the scan direction.
  const Eigen::Vector2d a = rays.Project(Eigen::Vector3d(0, 0, height));
  const Eigen::Vector2d b =
      rays.Project(Eigen::Vector3d(scan_direction.x(), scan_direction.y(), 0) * 5.0 + Eigen::Vector3d(0, 0, height));
  const bool along_rows = !(a.allFinite() && b.allFinite()) || std::abs(b.x() - a.x()) >= std::abs(b.y() - a.y());
  const int lines = along_rows ? h : w;
  const int length = along_rows ? w : h;
  auto value = [&](int line, int s) { return along_rows ? blurred.at<float>(line, s) : blurred.at<float>(s, line); };
  auto allowed = [&](int line, int s) {
    return mask[along_rows ? static_cast<std::size_t>(line) * w + s : static_cast<std::size_t>(s) * w + line] != 0;
  };

  std::vector<cv::Point2f> candidates;
  for (int line = 0; line < lines; ++line) {
    int best = -1;
    float best_value = options.min_peak;
    for (int s = 0; s < length; ++s) {
      if (allowed(line, s) && value(line, s) > best_value) {
        best_value = value(line, s);
        best = s;
      }
    }
    if (best < 0) continue;
    double offset = 0;
    if (best > 0 && best + 1 < length && allowed(line, best - 1) && allowed(line, best + 1)) {
      offset = InterpolatePeak(-1, value(line, best - 1), 0, best_value, 1, value(line, best + 1));
    }
    const double s = best + offset;
    const Eigen::Vector3d dir = along_rows ? rays.RayAt(s, line) : rays.RayAt(line, s);
    Eigen::Vector3d p;
    if (!IntersectHorizontalPlane(rays.centre(), dir, height, &p)) continue;
    candidates.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  }

  ReferenceLine result;
  result.height = height;
  result.candidates = static_cast<int>(candidates.size());
  if (result.candidates < options.min_candidates) return result;
  Eigen::Vector2d point, dir;
  FitLine(candidates, cv::DIST_HUBER, &point, &dir);
  // Outliers (specks of noise or reflections above the threshold): farther
  // than 3 robust sigmas (1.4826 MAD) from the Huber line.
  const Eigen::Vector2d normal(-dir.y(), dir.x());
  std::vector<double> distances;
  for (const auto& c : candidates) distances.push_back(std::abs(normal.dot(Eigen::Vector2d(c.x, c.y) - point)));
  std::vector<double> sorted = distances;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double tolerance = std::max(3 * 1.4826 * sorted[sorted.size() / 2], options.min_inlier_tolerance_mm);
  std::vector<cv::Point2f> inliers;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (distances[i] <= tolerance) inliers.push_back(candidates[i]);
  }
  if (static_cast<int>(inliers.size()) < options.min_candidates) return result;
  FitLine(inliers, cv::DIST_L2, &point, &dir);
  double sum_squares = 0, spread = 0;
  const Eigen::Vector2d n(-dir.y(), dir.x());
  for (const auto& c : inliers) {
    const Eigen::Vector2d d = Eigen::Vector2d(c.x, c.y) - point;
    sum_squares += std::pow(n.dot(d), 2);
    spread += std::pow(dir.dot(d), 2);
  }
  const double count = static_cast<double>(inliers.size());
  result.valid = true;
  result.point = point;
  result.direction = dir;
  result.inliers = static_cast<int>(inliers.size());
  result.rms_mm = std::sqrt(sum_squares / count);
  // Least-squares line: var(offset) = s^2 / n, var(angle) = s^2 / sum t^2,
  // with s^2 the residual variance (n - 2 degrees of freedom), both scaled
  // by the scanlines one independent sample spans after the pre-filter.
  const double residual_variance =
      sum_squares / std::max(1.0, count - 2) * CorrelatedScanlines(options.gaussian_sigma_px);
  result.offset_sigma_mm = std::sqrt(residual_variance / count);
  result.direction_sigma_rad = spread > 0 ? std::sqrt(residual_variance / spread) : 0.0;
  return result;
}

}  // namespace mesocap::calibration
