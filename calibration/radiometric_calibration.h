// The rig's radiometry from images of a white reference: a flat diffuse
// plate of known albedo rho over the turntable, imaged by every camera under
// each lamp alone. At a point of the plate a camera's linear signal is
//   v = t G_c (rho / pi) I_l cos(theta) / r^2
// (t exposure, G_c the camera's gain, I_l the lamp's RGB radiant intensity,
// theta and r the lamp's incidence and distance; btf/btf_assembly.h,
// "Radiometry"), so each (camera, lamp, channel) gives the product G_c I_l
// from the calibrated geometry alone. The products are fitted in the log
// domain, log G_c + log I_l; one common scale between gains and intensities
// is free (it cancels in every BTF value) and is fixed by keeping the
// geometric mean of the lamps' nominal intensities.
//
// Conditioning: a product is the mean of per-pixel ratios over the plate
// inside the sample square, its sigma their scatter over sqrt(pixels); a
// lamp near grazing (cos theta small) or a camera seeing few pixels of the
// square gives a large sigma, not a silent bias. Saturated or unlit pixels
// are left out; a (camera, lamp) with too few left is an error naming both.
// The fit's covariance is scaled up by its reduced chi-square when the
// products disagree beyond their sigmas (a model error the scatter misses).
// Lamp positions that carry an uncertainty (from the mirror sphere) add
// theirs: an error dD in a lamp's distance D moves its products by 2 dD / D,
// which the scale the lamps' mean holds passes on to every gain. It is
// propagated by refitting with each lamp moved by its sigma along each axis.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/image.h"
#include "formats/calibration.h"

namespace mesocap::calibration {

struct WhiteReferenceImage {
  int camera = 0;  // index into the calibration's cameras
  int lamp = 0;    // index into the calibration's lamps
  double arc_rad = 0.0;
  std::string name;   // for messages: the file it came from
  core::Image image;  // linear signal, fraction of full scale, RGB
};

struct RadiometryOptions {
  double albedo = 0.8;        // the white reference's, diffuse, grey
  double height_mm = 0.0;     // its top above the reference plane
  double sample_size_mm = 0;  // side of the sample square the BTF covers
  // Of the sample square, the centred part whose pixels are used (its edge
  // pixels mix the square's surroundings into the camera's footprint).
  double square_fraction = 0.8;
  double max_signal = 0.95;  // above: saturated or nearly
  double min_signal = 1e-3;  // below: unlit or read noise
  int min_pixels = 16;       // per (camera, lamp)
  core::CheckResult Check() const;
};

struct RadiometryResult {
  // Per calibration camera: G with its sigma.
  std::vector<formats::CameraRadiometry> cameras;
  // Per calibration lamp: its id, I (RGB) with its sigma.
  std::vector<std::string> lamp_ids;
  std::vector<Eigen::Vector3d> lamp_intensity, lamp_intensity_sigma;
  int images_used = 0;
  // RMS over the products of (fit - measured) / measured, and the reduced
  // chi-square of the fit (1 when the products agree within their sigmas).
  double relative_residual_rms = 0.0;
  double reduced_chi_square = 0.0;
};

// `geometry` gives the cameras (their rays), light arc and lamp positions
// and the nominal lamp intensities (the scale). Every (camera, lamp) pair
// needs one image. `exposure_s` per camera. Throws Error naming the camera,
// lamp and image when a pair is missing or has too few usable pixels.
RadiometryResult CalibrateRadiometry(const formats::Calibration& geometry, const std::vector<double>& exposure_s,
                                     const std::vector<WhiteReferenceImage>& images, const RadiometryOptions& options);

}  // namespace mesocap::calibration
