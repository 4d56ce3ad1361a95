// What the simulated rig's cameras see (MDF paper Sec. 3.1-3.2): the sample
// on the turntable lit by the lamps of the light arc, or by the laser stripe
// sweeping across it, or the stripe on a flat plate for the laser-plane
// calibration.
//
// Geometry (formats/rig_description.h, sim/true_calibration.h): the sample is
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
// must cope with the ghost peaks it leaves): see LaserSweepRenderer
// (sim/laser_sweep_renderer.h).
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
  // The stripe's peak signal in camera `camera` for a white diffuse point
  // facing the source (its exposure, 0 dB), before reflectance and cosine.
  double LaserGain(int camera) const;

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

// A rotation of `angle_rad` about the world's +z: the turntable's and the
// light arc's.
Eigen::Matrix3d RotationZ(double angle_rad);
// The laser is one colour; a grey sensor response to it sees the mean of
// the RGB reflectance.
double Grey(const Eigen::Vector3f& rgb);

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
