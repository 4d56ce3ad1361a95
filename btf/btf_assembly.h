// The BTF from a capture session's images (Wang et al. 2005 Sec. 3.1): each
// image -- one camera, turntable angle, light-arc angle and lamp -- is
// rectified into texture space (btf_rectification.h), made radiometric and
// placed at its (view, light) pair of the session's direction sets.
//
// Radiometry: the cameras record linear values (fraction of full scale; the
// 16-bit files hold code / (2^bits - 1), no gamma), value = L t G with L the
// radiance, t the exposure and G the camera's gain (signal per radiance
// second; each camera's own, from its calibration's radiometry). A lamp of radiant intensity I at distance r and angle
// theta_l from the sample normal gives the irradiance E = I cos(theta_l) / r^2 at a texel; T = L / E, per texel (r and
// theta_l vary across the sample). That is mesocap's T (sim/ground_truth.h: T = f_r (n.l) / cos theta_l; a flat
// Lambertian sample has T = albedo / pi). Conditioning: 1 / cos theta_l grows
// at grazing lamps, amplifying noise; a lamp at or below the sample plane is
// an error.
//
// Directions: each image's view and light direction in the sample frame
// (from the sample centre to the camera centre and to the lamp) is matched to
// the nearest direction of the session's sets; farther than
// max_direction_error_deg is an error unless `resample` is set, which
// resamples the captures onto the sets (btf_resampling.h), each texel with
// its own directions. Within the sample the true directions vary by the
// sample's angular size seen from the camera or lamp (~1.5 degrees for a
// 12 mm sample at 450 mm); matched to the grid, the BTF ignores that, as the
// paper's does (on the tiny rig's weave that costs nothing measurable: the
// truth along each texel's own directions is 48 dB from the grid truth).
//
// Pairs the rig never captures (a light direction that, in the sample frame,
// only occurs at other turntable angles than the view's) are filled by
// interpolating the view's measured lights (SamplingSet::Interpolate over
// them) and counted in the report; they are estimates, not measurements.
#pragma once

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "calibration/texel_grid.h"
#include "core/btf.h"
#include "core/error.h"
#include "core/image.h"
#include "formats/calibration.h"
#include "formats/capture_session.h"
#include "formats/captured_session.h"

namespace mesocap::btf {

struct BtfCaptureImage {
  std::filesystem::path file;
  std::optional<core::FileChecksum> checksum;  // checked before the image is decoded, when known
  int camera = 0;                              // index into Calibration::cameras
  double turntable_rad = 0.0;
  double arc_rad = 0.0;
  int lamp = 0;  // index into Calibration::lamps
};

struct BtfAssemblyOptions {
  calibration::TexelGrid texels{64, 64, 0.0};  // of the rectified images; the sample size must be set
  core::SamplingSet views;                     // the session's direction sets
  core::SamplingSet lights;
  std::vector<double> exposure_s;                  // per calibration camera, > 0
  std::vector<double> signal_per_radiance_second;  // per calibration camera: its gain G, > 0
  int max_samples_per_side = 8;                    // rectification's prefilter limit
  // Without resampling: how far an image's direction (from the sample
  // centre) may be from the nearest of the sets. With it: within this, a
  // target pair counts as measured rather than interpolated.
  double max_direction_error_deg = 1.0;
  // Off-grid captures resampled onto the sets (btf_resampling.h) instead of
  // matched to the nearest direction.
  bool resample = false;
  // Resampling with each texel's own view and light directions (else the
  // sample centre's for all texels).
  bool per_texel_directions = true;
  // Captured polar angles within this share a ring when resampling.
  double ring_tolerance_deg = 0.5;

  core::CheckResult Check() const;
};

struct BtfAssemblyReport {
  int images = 0;
  int measured_pairs = 0;  // (view, light) pairs with an image
  int filled_pairs = 0;    // interpolated from the view's measured lights (or resampled)
  bool resampled = false;
  // Resampling: target views, and the most target lights of any captured
  // view, outside the captured polar range (clamped to the nearest ring).
  int extrapolated_views = 0;
  int extrapolated_lights = 0;
  std::vector<std::vector<bool>> measured;  // [view][light]
  double max_view_offset_deg = 0.0;         // image direction to its set direction
  double max_light_offset_deg = 0.0;
  int max_samples_per_side = 1;  // the rectification prefilter's largest n
  // The narrowest texel footprint in pixels over all views
  // (ReferencePlaneRectifier::min_pixels_per_texel); below 1 the cameras do
  // not resolve the texture grid.
  double min_pixels_per_texel = 0.0;
  // The same per view of the sets (resampled: the nearest captured view's).
  std::vector<double> pixels_per_texel;
};

// The BTF images of a capture session's done steps (formats/captured_session.h;
// written by `mesocap simulate` or a rig): one "btf_image" step per turntable
// angle, arc angle and lamp (turntable_deg, arc_deg, lamp), one file per
// camera ({camera: id, path}), each with the checksum its journal records.
// Cameras are matched to the calibration by id; throws FormatError naming
// the manifest and the step for a bad step.
std::vector<BtfCaptureImage> SessionBtfImages(const formats::CapturedSession& session,
                                              const formats::Calibration& calibration);

// Receives each assembled view image of the BTF (3 channels, W x H * Nlight,
// light l in rows [l*H, (l+1)*H)), once per view, in any order, never two
// calls at once.
using BtfViewSink = std::function<void(int view, core::Image&& values)>;

// Reads, rectifies and calibrates every image; throws Error naming the file
// for a missing or unreadable image, one not stored as 16-bit samples (a
// session's frames: formats::SessionFrameReadOptions), a size that differs from the calibrated camera's, a direction
// off the sets, two images of the same pair, or a view with no image.
// Each view is handed to `sink` as soon as it is done, so a large BTF can go
// to disk without ever being whole in memory: on the grid, views are built
// from their own images, at most one per worker at a time; resampling first
// holds every captured view's light-resampled image (about one BTF).
void AssembleBtfViews(const std::vector<BtfCaptureImage>& images, const formats::Calibration& calibration,
                      const BtfAssemblyOptions& options, const BtfViewSink& sink, BtfAssemblyReport* report = nullptr);
// The same, into memory.
core::FullBtf AssembleBtf(const std::vector<BtfCaptureImage>& images, const formats::Calibration& calibration,
                          const BtfAssemblyOptions& options, BtfAssemblyReport* report = nullptr);

}  // namespace mesocap::btf
