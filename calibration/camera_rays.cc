#include "calibration/camera_rays.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "core/error.h"

namespace mesocap::calibration {
namespace {

cv::Matx33d CameraMatrix(const formats::CameraCalibration& c) {
  return {c.intrinsics.fx, 0, c.intrinsics.cx, 0, c.intrinsics.fy, c.intrinsics.cy, 0, 0, 1};
}

std::vector<double> DistortionCoefficients(const formats::CameraCalibration& c) {
  return {c.distortion.k1, c.distortion.k2, c.distortion.p1, c.distortion.p2, c.distortion.k3};
}

}  // namespace

CameraRays::CameraRays(const formats::CameraCalibration& camera)
    : width_(camera.width),
      height_(camera.height),
      centre_(camera.pose.transform.translation),
      world_from_camera_(camera.pose.transform.rotation),
      camera_(camera) {
  if (width_ <= 0 || height_ <= 0) throw core::Error("camera " + camera.id + ": image size must be positive");
  std::vector<cv::Point2d> pixels;
  pixels.reserve(static_cast<std::size_t>(width_) * height_);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) pixels.emplace_back(x, y);
  }
  std::vector<cv::Point2d> normalized;
  // Iterative undistortion to 1e-12 (OpenCV's default of 5 steps leaves
  // ~0.01 px at the corners of a k1 = -0.08 lens).
  cv::undistortPoints(pixels, normalized, CameraMatrix(camera), DistortionCoefficients(camera), cv::noArray(),
                      cv::noArray(), cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-12));
  rays_.resize(normalized.size());
  for (std::size_t i = 0; i < normalized.size(); ++i) {
    rays_[i] = (world_from_camera_ * Eigen::Vector3d(normalized[i].x, normalized[i].y, 1.0)).normalized();
  }
}

Eigen::Vector3d CameraRays::RayAt(double u, double v) const {
  u = std::clamp(u, 0.0, width_ - 1.0);
  v = std::clamp(v, 0.0, height_ - 1.0);
  const int x0 = std::min(static_cast<int>(u), width_ - 2 < 0 ? 0 : width_ - 2);
  const int y0 = std::min(static_cast<int>(v), height_ - 2 < 0 ? 0 : height_ - 2);
  const int x1 = std::min(x0 + 1, width_ - 1);
  const int y1 = std::min(y0 + 1, height_ - 1);
  const double fx = u - x0, fy = v - y0;
  const Eigen::Vector3d top = (1 - fx) * Ray(x0, y0) + fx * Ray(x1, y0);
  const Eigen::Vector3d bottom = (1 - fx) * Ray(x0, y1) + fx * Ray(x1, y1);
  return ((1 - fy) * top + fy * bottom).normalized();
}

Eigen::Vector2d CameraRays::Project(const Eigen::Vector3d& world) const {
  const Eigen::Vector3d in_camera = world_from_camera_.transpose() * (world - centre_);
  if (in_camera.z() <= 0) return Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  std::vector<cv::Point3d> object = {{in_camera.x(), in_camera.y(), in_camera.z()}};
  std::vector<cv::Point2d> image;
  cv::projectPoints(object, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), CameraMatrix(camera_),
                    DistortionCoefficients(camera_), image);
  return {image[0].x, image[0].y};
}

bool IntersectHorizontalPlane(const Eigen::Vector3d& centre, const Eigen::Vector3d& dir, double height,
                              Eigen::Vector3d* point) {
  if (std::abs(dir.z()) < 1e-9) return false;
  const double t = (height - centre.z()) / dir.z();
  if (t <= 0) return false;
  *point = centre + t * dir;
  return true;
}

}  // namespace mesocap::calibration
