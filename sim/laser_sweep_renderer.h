// The laser stripe's frames of one camera: a whole sweep's, rendered from
// the samples its range of tilts can light, and a single frame's (a laser
// plate's). Part of the camera renderer (sim/camera_renderer.h), which
// keeps one sweep per camera.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <numbers>
#include <vector>

#include "core/image.h"
#include "formats/calibration.h"
#include "sim/camera_renderer.h"

namespace mesocap::sim {

// A laser sweep of one camera from one laser location (Sec. 3.2: the
// sequence {I_v,l(x, y, t_i)}): everything that does not depend on the tilt
// (the hits, their reflectance towards the source, the source's visibility:
// one shadow ray per sample) is computed once here, with the range of tilts
// over which the stripe (cut off at 8 sigma) covers each lit sample. Frame(tilt)
// then visits only the samples whose range holds the tilt: a paper-rig
// frame's stripe covers ~5 % of the image, and the cost scales with that,
// not with the image.
//
// With interreflection_rays_per_pixel = K > 0, each pixel also gathers the
// stripe's light reflected once by the mesostructure: K cosine-distributed
// rays from its sample points (spread over the pixel's sub-samples) find
// the points q that light could come from; q's place relative to the plane,
// its lighting by the source and both reflectances are fixed for the sweep,
// so each q is one more stripe sample with weight
//   gain pi / K  grey(f_s(w, v) f_q(l_q, -w)) (n_q.l_q) V_q
// (the cosine-weighted estimator of the one-bounce integral). A pixel then
// sees a second, fainter peak when the stripe crosses what it sees lit
// (the ghost peaks of Sec. 3.2). Deterministic: each pixel's directions
// come from a generator seeded by its index.
class LaserSweepRenderer {
 public:
  // Keeps a reference to `view`, which must outlive the sweep: a lit
  // sample's point is read from it at every frame. Frames are rendered at
  // tilts in [-max_tilt_rad, max_tilt_rad]; the samples lit only beyond
  // are not kept.
  LaserSweepRenderer(const CameraRenderer& renderer, const CameraView& view, int mount, double arc_rad,
                     double max_tilt_rad = std::numbers::pi);

  // The stripe's signal at one tilt (an error beyond the sweep's maximum):
  // 1 channel, before the sensor.
  core::Image Frame(double tilt_rad) const;

  // One frame without the sweep: each sample's distance from the plane at
  // `tilt_rad` is tested first, and only the samples within the cutoff are
  // lit. Direct light only (no interreflection: that needs the whole view's
  // bounce points), so for a view with no mesostructure in it, as a laser
  // plate's: there it equals Frame(tilt_rad) but for the order in which a
  // pixel adds its samples, at a tiny fraction of building the sweep.
  static core::Image SingleFrame(const CameraRenderer& renderer, const CameraView& view, int mount, double arc_rad,
                                 double tilt_rad);

 private:
  // The plane's geometry and the stripe's width only; the public
  // constructor then lights and bins the view's samples.
  LaserSweepRenderer(const CameraRenderer& renderer, const CameraView& view, int mount, double arc_rad,
                     double max_tilt_rad, bool light_samples);
  // The signed distance of a point from the plane at tilt t is
  // cos(t) a + sin(t) b + c (Rodrigues' rotation of the tilt-0 normal), with
  // a, b, c linear in the point, computed from it at every frame so that a
  // lit sample keeps only its index and its stripe (28 bytes binned, with its point; every camera's
  // sweep is held at once, 7 million samples for a paper-rig camera). The
  // stripe's profile over the sample's footprint is a Gaussian of variance
  // sigma^2 + StripeFootprintVariance (weight scaled by sigma / that sigma,
  // so the light it gets over a sweep stays the same), cut off at 8 of it.
  struct Distance {
    double a = 0, b = 0, c = 0;
  };
  // Over a turn of the plane, d(t) = r cos(t - phi) + c comes within the
  // cutoff of a point in one interval of t or in two mirrored about phi;
  // an entry of the latter counts only on its own side, where
  // sin(t - phi) has the entry's sign.
  enum class Side : std::uint32_t { kAny = 0, kAfterPhi = 1, kBeforePhi = 2 };
  struct LitSample {
    // Bits 0-28: the view sample's index, or with kBounceBit the entry of
    // bounces_; bits 29-30: the Side.
    std::uint32_t source = 0;
    float weight = 0;  // signal the pixel gets at the stripe's peak
    float inv_two_sigma2 = 0;
  };
  static constexpr std::uint32_t kIndexBits = 29;
  static constexpr std::uint32_t kIndexMask = (1u << kIndexBits) - 1;
  static constexpr std::uint32_t kBounceBit = 1u << 31;
  // A point lit by the stripe's light after one bounce and the pixel it adds to.
  struct BouncePoint {
    Eigen::Vector3f point = Eigen::Vector3f::Zero();
    std::uint32_t pixel = 0;
  };
  // A lit sample while the sweep is built: the tilts [begin, end] (in
  // [-pi, pi], padded) over which the stripe covers it, for binning.
  struct RangedSample {
    LitSample lit;
    float begin = 0, end = 0;
  };
  Distance DistanceOf(const Eigen::Vector3d& point) const;
  // The signal a view sample gets at the stripe's peak (MDF paper Sec. 3.2:
  // its reflectance towards the camera, lit by the source, seen through its
  // pixel's box filter); 0 where the source is behind its surface or hidden
  // from it.
  double DirectWeight(const CameraRenderer& renderer, const ViewSample& s) const;
  // The stripe's weight and Gaussian for a sample of peak signal `weight`
  // whose distance from the plane varies by `footprint_variance` (mm^2)
  // over its footprint.
  LitSample Stripe(std::uint32_t source, double weight, double footprint_variance) const;
  // Adds the lit sample's tilt range(s) for a point to `lit` (none when
  // never covered).
  void AddLit(LitSample s, const Eigen::Vector3d& point, std::vector<RangedSample>* lit) const;
  // Appends one list of bounce samples per row to `rows`, their points to bounces_.
  void AddBounces(const CameraRenderer& renderer, const CameraView& view, double gain, int rays_per_pixel,
                  std::vector<std::vector<RangedSample>>* rows);
  // Sorts the lit samples, list after list, into bins by the start of the
  // range (a counting sort: stable, so frames add in the same order on every
  // run); ranges wider than kMaxBinnedSpan go to wide_, checked at every
  // frame. Straight from the per-row lists: joining them first would fault
  // in another copy of them (tens of MB a sweep).
  void Bin(const std::vector<std::vector<RangedSample>>& rows);
  // The bin of a range starting at `begin` (clamped to the first and last).
  std::size_t BinOf(double begin) const;
  // The tilt-0 plane's rotation about the tilt axis k (Rodrigues):
  // n(t) = cos(t) n0 + sin(t) (k x n0) + (1 - cos(t)) (k.n0) k.
  Eigen::Vector3d source_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d n0_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d k_cross_n0_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d k_k_n0_ = Eigen::Vector3d::Zero();
  const CameraView& view_;
  double max_tilt_ = 0.0;
  int width_ = 0;
  int height_ = 0;
  double sigma_mm_ = 1.0;
  // The view's camera centre and the peak signal per unit reflectance.
  Eigen::Vector3d camera_centre_ = Eigen::Vector3d::Zero();
  double gain_ = 0.0;
  std::vector<BouncePoint> bounces_;
  // A binned lit sample keeps its range's end and its point: a frame
  // visits every bin that a range holding its tilt can start in, passes
  // over the samples whose range ended before it, and reads the others in
  // bin order; a point read from the view instead was a cache miss each.
  struct BinnedSample {
    LitSample lit;
    float end = 0;
    Eigen::Vector3f point = Eigen::Vector3f::Zero();
  };
  // The world point of a lit sample: its view sample's or its bounce's.
  const Eigen::Vector3f& PointOf(const LitSample& s) const;
  // Binned lit samples: bin i holds binned_[bin_begin_[i], bin_begin_[i + 1]),
  // ranges starting in [first_begin_ + i bin_width_, + bin_width_).
  std::vector<BinnedSample> binned_;
  std::vector<std::uint32_t> bin_begin_;
  double first_begin_ = 0.0;
  double bin_width_ = 1.0;
  double max_span_ = 0.0;  // of the binned ranges
  std::vector<LitSample> wide_;
};

// A camera sample covers 1 / side of a pixel on each axis, and its footprint
// on the surface (the tangent plane of the sample's hit) is a parallelogram;
// a stripe narrower than that (at grazing views a paper-rig pixel spans
// 1 mm of a sample, the stripe's sigma is 0.15 mm) would alias between the
// sample points, so the sweep renderer widens the stripe by the variance of
// the distance from the plane (normal `plane_normal`) over the footprint:
// (g_u^2 + g_v^2) / 12, g the change of that distance across the footprint
// on each image axis (the box filter's variance). Pinhole Jacobian (the
// lens distortion changes a footprint by ~k1 r^2, a few percent at the
// corners); the tangent plane is taken at least kMinFootprintCosine from
// edge-on, where the footprint would have no bound.
inline constexpr double kMinFootprintCosine = 0.05;
double StripeFootprintVariance(const formats::CameraCalibration& camera, const ViewSample& sample,
                               const Eigen::Vector3d& plane_normal, int samples_per_pixel_side);

}  // namespace mesocap::sim
