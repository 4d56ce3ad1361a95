// Rectification of a captured image into texture space (Wang et al. 2005
// Sec. 3.1: "the captured images are rectified and then clipped to form the
// output BTF data"): the centre p of texel (i, j) of the texel grid
// (calibration/texel_grid.h) is projected into the camera with its
// calibrated pose, pinhole and Brown-Conrady distortion. The camera ray
// through p is the ray the true BTF is defined on (sim/ground_truth.h: the
// first hit along -view from p).
//
// Filtering: the texel averages n x n samples over its footprint (a box
// prefilter, n = the footprint's extent in pixels, rounded up, at most
// max_samples_per_side), each sample reconstructed from the image by
// Catmull-Rom bicubic interpolation (4 x 4 taps). A pixel of the camera
// already integrates over its area; bilinear reconstruction adds a second,
// 2-pixel-wide tent blur on top, which on the weave cost 1.5 dB at 8 x 8
// texels and 2.7 dB at 16 x 16 on the tiny rig (docs/BENCHMARKS.md "Rectification
// and resampling"). Catmull-Rom is interpolating and exact for quadratics; its
// negative lobes raise pixel noise by ~1 dB (0.64 vs 0.5 noise power at
// half-pixel offsets) and can leave slightly negative values beside black
// edges, kept unclamped so that noise averages out unbiased.
//
// Conditioning: at grazing views the footprint stretches along one axis
// (1 / cos theta) and n follows the longer extent. Where the footprint is
// narrower than a pixel along some texture direction
// (min_pixels_per_texel() < 1) the camera samples the texture more coarsely
// than the grid: the texels there are interpolated, not resolved, and detail
// finer than the camera's pixels is lost (the weave at 16 x 16 texels on the
// tiny rig: 0.9 pixels per texel at 60 degrees, 31 dB where 8 x 8 reaches
// 36.6 dB).
#pragma once

#include <string>
#include <vector>

#include "calibration/camera_rays.h"
#include "calibration/texel_grid.h"
#include "core/image.h"
#include "formats/calibration.h"

namespace mesocap::btf {

class ReferencePlaneRectifier {
 public:
  // Throws Error, naming the camera, when a texel's footprint leaves the
  // image or lies behind the camera.
  // Projects with the camera's CameraRays (cv::projectPoints).
  ReferencePlaneRectifier(const formats::CameraCalibration& camera, const calibration::CameraRays& rays,
                          const core::RigidTransform& world_from_sample, const calibration::TexelGrid& grid,
                          int max_samples_per_side = 8);

  // The camera image (any channel count) in texture space, W x H.
  core::Image Rectify(const core::Image& camera_image) const;

  int samples_per_side_max() const { return samples_per_side_max_; }
  // Smallest footprint width in pixels over all texels and texture
  // directions (the smaller singular value of the texel-to-pixel Jacobian).
  double min_pixels_per_texel() const { return min_pixels_per_texel_; }

 private:
  struct Tap {
    int pixel = 0;  // y * image width + x
    float weight = 0.0f;
  };
  int width_ = 0;
  int height_ = 0;
  int image_width_ = 0;
  int image_height_ = 0;
  int samples_per_side_max_ = 1;
  double min_pixels_per_texel_ = 0.0;
  std::vector<int> first_tap_;  // per texel, into taps_; one past the end at [W*H]
  std::vector<Tap> taps_;
};

}  // namespace mesocap::btf
