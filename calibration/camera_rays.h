// The rays of a calibrated camera (OpenCV pinhole + Brown-Conrady model,
// formats/calibration.h), precomputed once per camera for every pixel so the
// per-frame work of Sec. 3.2 (laser line detection, space-time
// triangulation) never undistorts a point.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "formats/calibration.h"

namespace mesocap::calibration {

class CameraRays {
 public:
  // Undistorts every pixel centre (pixel (i, j) at u = i, v = j) with
  // cv::undistortPoints. Throws Error on a non-positive image size.
  explicit CameraRays(const formats::CameraCalibration& camera);

  int width() const { return width_; }
  int height() const { return height_; }
  const Eigen::Vector3d& centre() const { return centre_; }
  // Unit world direction of the ray through pixel (x, y).
  const Eigen::Vector3d& Ray(int x, int y) const { return rays_[static_cast<std::size_t>(y) * width_ + x]; }
  // Ray through a sub-pixel position, bilinear in the pixel rays (adjacent
  // rays differ by ~1 mrad, so the blend is exact to far below a pixel);
  // positions are clamped to the image.
  Eigen::Vector3d RayAt(double u, double v) const;
  // Pixel position of a world point (cv::projectPoints); NaN behind the camera.
  Eigen::Vector2d Project(const Eigen::Vector3d& world) const;

 private:
  int width_ = 0;
  int height_ = 0;
  Eigen::Vector3d centre_;
  Eigen::Matrix3d world_from_camera_;
  formats::CameraCalibration camera_;
  std::vector<Eigen::Vector3d> rays_;
};

// Where the ray centre + t dir meets the horizontal plane z = height; false
// when it runs parallel to it (|dir.z| < 1e-9) or meets it behind the centre.
bool IntersectHorizontalPlane(const Eigen::Vector3d& centre, const Eigen::Vector3d& dir, double height,
                              Eigen::Vector3d* point);

}  // namespace mesocap::calibration
