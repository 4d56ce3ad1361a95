// What the simulated rig's cameras see (MDF paper Sec. 3.1-3.2): the sample
// on the turntable lit by the lamps of the light arc, or by the laser stripe
// sweeping across it, or the stripe on a flat plate for the laser-plane
// calibration.
//
// Geometry (drivers/rig_description.h, sim/true_calibration.h): the sample is
// the clipped square of side rig.sample_size_mm centred on the sample-frame
// origin, x_world = Rz(turntable) x_sample, with the tiled mesostructure in
// -d_max <= z <= 0 inside the square. The sample sits in a pocket of the
// turntable, its reference plane flush with the turntable plane z = 0:
// outside the square a camera ray meets the turntable (diffuse grey, albedo
// 0.3, the "reference region" of Sec. 3.2's laser-line detection); inside it
// the mesostructure, or where the ray finds none (through a hole) the
// pocket's backing board (rig.backing, diffuse grey) or, without one or past
// the pocket walls, black. Light reaching a point inside the pocket must
// leave through the open square: a shadow ray that would leave the slab
// outside it is blocked by the pocket wall. Camera poses and lamp and laser
// mount positions come from TrueCalibration, the single source of rig
// geometry; cameras follow OpenCV's model (pinhole + Brown-Conrady k1 k2 p1
// p2 k3), pixel (i, j) centred at u = i, v = j.
//
// Each pixel averages samples_per_pixel_side^2 rays on a regular sub-pixel
// grid (a box filter, as a pixel integrates over its area): edges and the
// stripe, whose sigma is below a pixel's footprint on the shipped rigs, come
// out with sub-pixel information instead of aliasing.
//
// Radiometry: a lamp (a point source of radiant intensity I) adds
// f_r I / r^2 (n.l) V to the radiance the camera sees; the laser adds
// f_r E_peak exp(-d^2 / (2 sigma^2)) (n.l_laser) V_laser, d the point's
// distance from the laser plane. V is 1 when the light reaches the point
// (one shadow ray), else 0. Lamps light directly only. The laser's light can
// also arrive after one bounce off the mesostructure (options: the paper
// suppresses that with a short shutter, Sec. 3.2, but a processing pipeline
// must cope with the ghost peaks it leaves): see LaserSweepRenderer.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <mutex>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "calibration/board_print.h"
#include "calibration/nominal_geometry.h"
#include "core/image.h"
#include "formats/calibration.h"
#include "formats/rig_description.h"
#include "sim/mesostructure_scene.h"
#include "sim/simulated_rig_state.h"
#include "sim/undistorted_grid.h"

namespace mesocap::sim {

// Signal (fraction of full scale) = radiance x exposure time x this gain,
// radiance in the rig's relative units (lamp intensity / mm^2). Chosen so
// that full scale is a white Lambertian surface at normal incidence under
// twice the irradiance of a unit-intensity lamp at 450 mm (the shipped rigs'
// lamp distance), exposed 20 ms (their exposure): G = pi 450^2 / (2 x 0.02 s).
// Then the albedo-0.5 samples under the lamps give 0.15-0.25 of full scale
// (the turntable 0.1-0.15), and the laser stripe (power 4 = four times a
// lamp's irradiance) 0.4-0.9 at its peak, near but, for typical albedos,
// below saturation.
inline constexpr double kSignalPerRadianceSecond = std::numbers::pi * 450.0 * 450.0 / (2.0 * 0.02);
// Diffuse albedos of the rig's own surfaces.
inline constexpr float kTurntableAlbedo = 0.3f;
inline constexpr float kCalibrationPlateAlbedo = 0.5f;

struct CameraRendererOptions {
  int samples_per_pixel_side = 3;
  // Rays per pixel gathering the laser's light after one bounce off the
  // mesostructure (0: direct light only). 0..256.
  int interreflection_rays_per_pixel = 0;
};

// What one camera ray meets; points and normals in the world frame, in
// float (0.06 um at 1 m from the origin, far below the scene's surface
// epsilon (1e-4 of a tile) that shadow and bounce rays start past).
struct ViewSample {
  enum class Surface : std::uint8_t { kNothing, kSample, kTurntable, kCalibrationPlate, kBacking };
  Surface surface = Surface::kNothing;
  Eigen::Vector3f point = Eigen::Vector3f::Zero();
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
  Reflectance reflectance;

  Eigen::Vector3d Point() const { return point.cast<double>(); }
  Eigen::Vector3d Normal() const { return normal.cast<double>(); }
};

// The first hits of every sub-pixel ray of one camera in one setting (a
// turntable angle, or a calibration plate): computed once, then lit by any
// number of lamp settings and laser tilts. Pixel p's samples are
// p * samples_per_pixel + k, k < samples_per_pixel, p = y W + x.
//
// A view holds one sample per sub-pixel ray (7 million for a paper-rig
// camera at 3 x 3 rays a pixel) and every camera's is kept, so a sample is
// kept in 40 bytes (a ViewSample takes 48): its gloss (specular albedo and
// exponent, constant over a scene part) is an index into the view's few
// distinct glosses.
struct CameraView {
  struct Gloss {
    float specular_albedo = 0.0f;
    float glossy_exponent = 20.0f;
  };
  struct StoredSample {
    ViewSample::Surface surface = ViewSample::Surface::kNothing;
    std::uint8_t gloss = 0;  // into glosses
    Eigen::Vector3f point = Eigen::Vector3f::Zero();
    Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();
    Eigen::Vector3f diffuse_albedo = Eigen::Vector3f::Constant(0.5f);
  };
  static constexpr int kMaxGlosses = 256;

  int camera = 0;
  double turntable_rad = 0.0;
  int width = 0;
  int height = 0;
  int samples_per_pixel = 1;
  std::vector<StoredSample> samples;
  std::vector<Gloss> glosses;

  // Sample `index` in full.
  ViewSample Sample(std::size_t index) const;
};

// A laser plane in the world frame: points x with normal.(x - source) = 0.
struct LaserPlane {
  Eigen::Vector3d source = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
};

class CameraRenderer : public FrameRenderer {
 public:
  // Keeps references to both; they must outlive the renderer.
  CameraRenderer(const MesostructureScene& scene, const formats::RigDescription& rig,
                 CameraRendererOptions options = {});

  // Lamps that are on plus the laser when on (added equally to R, G and B:
  // the grey response of the sensor to the laser's light), on the sample or,
  // while the operator has laid it there, the calibration plate; 3 channels
  // or, for a mono readout, 1 (their mean).
  // The camera's first hits stay cached while the turntable (or the plate)
  // stays put, and its sweep's stripe samples while the laser's mount and
  // the light arc do, so a capture that walks the rig in its plan's order
  // traces each camera once per turntable angle and a sweep frame costs
  // only the stripe (the pieces below). The cache holds one camera view per
  // camera: samples_per_pixel_side^2 stored samples a pixel.
  core::Image Render(const SimulatedRigState& state, int camera, int channels) override;

  // The rig's calibration board on holder `holder` at a turntable angle,
  // evenly lit (sim/board_photo_renderer.h); 1 or 3 equal channels. Throws
  // Error when the rig describes no calibration board.
  core::Image RenderCalibrationBoard(int camera, int holder, double turntable_rad, int channels) const;

  // First hits of the camera's rays on the sample at a turntable angle.
  CameraView TraceSample(int camera, double turntable_rad) const;
  // First hits on the laser calibration plate: a flat diffuse plate
  // (albedo 0.5) at z = height_mm over the whole turntable, no sample
  // (Sec. 3.2: the stripe on two planes of different height); with another
  // albedo, the white reference of the radiometric calibration.
  CameraView TracePlate(int camera, double height_mm, float albedo = kCalibrationPlateAlbedo) const;

  // What the ray through pixel position (u, v) meets on the sample (or the
  // turntable) at a turntable angle: one ray, no sub-pixel samples.
  ViewSample FirstHit(int camera, double turntable_rad, double u, double v) const;

  // Signal of the lamps that are on (lamps_on[i] for lamp i) at light-arc
  // angle arc_rad; 3 channels (RGB), before the sensor (camera_sensor.h).
  core::Image RenderLamps(const CameraView& view, double arc_rad, const std::vector<bool>& lamps_on) const;

  // The laser plane of `mount` with the light arc at arc_rad and the emitter
  // at `tilt_rad`: the mount's plane at tilt 0 turned about its tilt axis by
  // the tilt, then the whole mount about +z by the arc angle.
  LaserPlane LaserPlaneAt(int mount, double arc_rad, double tilt_rad) const;
  // Peak irradiance of the stripe: laser.power times the irradiance of the
  // rig's lamp (mean of its RGB intensity) at the lamp distance.
  double LaserPeakIrradiance() const;

  // Whether light from the world point `light` reaches sample `s` of
  // `view` (the turntable and the plate are never shadowed; a sample point
  // by the mesostructure or the pocket wall).
  bool Lit(const CameraView& view, const ViewSample& s, const Eigen::Vector3d& light) const;

  // What the ray from sample point s of `view` along world direction `dir`
  // (unit, into the upper hemisphere of s's normal) meets on the
  // mesostructure before it leaves the sample's slab through the reference
  // plane (nothing then, and nothing where it meets the black backing or
  // pocket wall): the second vertex of a one-bounce light path.
  std::optional<ViewSample> BounceHit(const CameraView& view, const ViewSample& s, const Eigen::Vector3d& dir) const;

  // The camera's centre and the world direction (unit) of the ray through
  // pixel position (u, v) (distorted, as in the image).
  Eigen::Vector3d CameraCentre(int camera) const;
  Eigen::Vector3d PixelRay(int camera, double u, double v) const;

  const formats::Calibration& calibration() const { return calibration_; }
  const formats::RigDescription& rig() const { return rig_; }
  const CameraRendererOptions& options() const { return options_; }

 private:
  template <typename HitFunction>
  CameraView Trace(int camera, double turntable_rad, const HitFunction& first_hit) const;
  // The memory of one view of `camera` (CameraView::samples), and its shape
  // in words, for the message when it cannot be had.
  std::uint64_t FirstHitBytes(int camera) const;
  std::string FirstHitsText(int camera) const;
  ViewSample SampleHit(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double turntable_rad) const;
  // Distance along d (sample frame) from p, inside the sample's slab, to
  // where the ray leaves it: the reference plane (open), the floor at
  // -d_max or the pocket's walls (both black).
  double SlabExit(const Eigen::Vector3d& p, const Eigen::Vector3d& d) const;

  // The undistorted samples of camera `camera` over (at least) `rect` at n
  // samples per pixel side, kept from the last photo that asked for the same
  // in the same slot (a calibration session takes many photos of the board
  // and of the sphere; n = 1 gives the pixels' centres).
  enum class PhotoSlot { kBoard, kSphere, kSphereCentres };
  std::shared_ptr<const UndistortedGrid> PhotoGrid(int camera, int n, PixelRect rect, PhotoSlot slot) const;

  // What Render keeps of one camera between frames.
  struct RenderCache;
  RenderCache& CachedRender(const SimulatedRigState& state, int camera);

  const MesostructureScene& scene_;
  std::optional<calibration::BoardPrint> board_print_;  // the rig's calibration board, if it has one
  const formats::RigDescription& rig_;
  CameraRendererOptions options_;
  formats::Calibration calibration_;
  std::vector<std::shared_ptr<RenderCache>> cache_;  // per camera
  mutable std::mutex photo_grids_mutex_;
  mutable std::vector<std::shared_ptr<const UndistortedGrid>> photo_grids_;  // 3 per camera, by PhotoSlot
};

// The tilts CameraRenderer renders a sweep at: a sweep tilts the emitter a
// few degrees about its rest, and beyond a quarter turn its fan would face
// away from the turntable. The plane at t + pi is the one at t, so each
// point's second crossing, half of a sweep's lit samples, lies out there.
inline constexpr double kMaxSweptTiltRad = std::numbers::pi / 2.0;

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
  // a diffuse-lit point seen through its pixel's box filter); 0 where the
  // source is behind its surface or hidden from it.
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

// The simulator's own camera model, apart from calibration/camera_rays.h (OpenCV) on purpose: the simulated truth
// must not share projection code with the processing it checks, so that a bug in either shows against the other.
//
// Brown-Conrady (OpenCV) distortion of normalized image coordinates, and its
// inverse by fixed-point iteration (at most 100 steps, stopping when a step
// moves less than 1e-14): accurate to far below 1e-3 px for the moderate
// distortion of real lenses.
Eigen::Vector2d Distort(const formats::Distortion& d, const Eigen::Vector2d& undistorted);
Eigen::Vector2d Undistort(const formats::Distortion& d, const Eigen::Vector2d& distorted);
// Projects a world point to pixel coordinates with a camera's calibration.
Eigen::Vector2d ProjectToPixel(const formats::CameraCalibration& camera, const Eigen::Vector3d& world);

}  // namespace mesocap::sim
