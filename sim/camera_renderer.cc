#include "sim/camera_renderer.h"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <new>
#include <numbers>
#include <random>
#include <sstream>

#include "core/error.h"
#include "sim/board_photo_renderer.h"
#include "sim/laser_sweep_renderer.h"
#include "sim/mirror_sphere_renderer.h"
#include "sim/true_calibration.h"

namespace mesocap::sim {
namespace {

// The rig's own flat grey surfaces (turntable, calibration plate, backing
// board): horizontal, diffuse.
ViewSample FlatGreySample(ViewSample::Surface surface, const Eigen::Vector3d& point_world, float albedo) {
  ViewSample s;
  s.surface = surface;
  s.point = point_world.cast<float>();
  s.normal = Eigen::Vector3f::UnitZ();
  s.reflectance.diffuse_albedo = Eigen::Vector3f::Constant(albedo);
  s.reflectance.specular_albedo = 0.0f;
  return s;
}

constexpr double kInfinity = std::numeric_limits<double>::infinity();

double ExposureSeconds(const formats::CameraDescription& camera) { return camera.exposure_us * 1e-6; }

// The distinct glosses of a view as its samples are traced in parallel:
// entries are appended under the lock and published through the count, so
// the common lookup (a scene has a gloss per part) reads without locking.
class GlossTable {
 public:
  std::uint8_t IndexOf(const Reflectance& r) {
    const int published = count_.load(std::memory_order_acquire);
    for (int i = 0; i < published; ++i) {
      if (Same(entries_[i], r)) return static_cast<std::uint8_t>(i);
    }
    const std::lock_guard<std::mutex> lock(mutex_);
    const int count = count_.load(std::memory_order_relaxed);
    for (int i = published; i < count; ++i) {
      if (Same(entries_[i], r)) return static_cast<std::uint8_t>(i);
    }
    if (count == CameraView::kMaxGlosses) {
      throw core::Error("camera renderer: more than " + std::to_string(CameraView::kMaxGlosses) +
                        " distinct specular albedos and exponents in one view");
    }
    entries_[count] = {r.specular_albedo, r.glossy_exponent};
    count_.store(count + 1, std::memory_order_release);
    return static_cast<std::uint8_t>(count);
  }
  std::vector<CameraView::Gloss> Entries() const { return {entries_.begin(), entries_.begin() + count_.load()}; }

 private:
  static bool Same(const CameraView::Gloss& g, const Reflectance& r) {
    return g.specular_albedo == r.specular_albedo && g.glossy_exponent == r.glossy_exponent;
  }
  std::array<CameraView::Gloss, CameraView::kMaxGlosses> entries_{};
  std::atomic<int> count_{0};
  std::mutex mutex_;
};

// Sub-pixel offset of sample k of n per side, on a regular grid inside the
// pixel [-0.5, 0.5]^2 around its centre.
Eigen::Vector2d SubPixelOffset(int k, int n) { return {((k % n) + 0.5) / n - 0.5, ((k / n) + 0.5) / n - 0.5}; }

}  // namespace

Eigen::Matrix3d RotationZ(double angle_rad) {
  return Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

double Grey(const Eigen::Vector3f& rgb) { return (rgb[0] + rgb[1] + rgb[2]) / 3.0; }

Eigen::Vector2d Distort(const formats::Distortion& d, const Eigen::Vector2d& p) {
  const double x = p.x(), y = p.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
  return {x * radial + 2.0 * d.p1 * x * y + d.p2 * (r2 + 2.0 * x * x),
          y * radial + d.p1 * (r2 + 2.0 * y * y) + 2.0 * d.p2 * x * y};
}

Eigen::Vector2d Undistort(const formats::Distortion& d, const Eigen::Vector2d& distorted) {
  // x = (x_d - tangential(x)) / radial(x): a contraction for real lenses'
  // distortion near the image, converging to double precision in a few
  // dozen steps.
  Eigen::Vector2d p = distorted;
  for (int i = 0; i < 100; ++i) {
    const double x = p.x(), y = p.y();
    const double r2 = x * x + y * y;
    const double radial = 1.0 + r2 * (d.k1 + r2 * (d.k2 + r2 * d.k3));
    const Eigen::Vector2d tangential(2.0 * d.p1 * x * y + d.p2 * (r2 + 2.0 * x * x),
                                     d.p1 * (r2 + 2.0 * y * y) + 2.0 * d.p2 * x * y);
    const Eigen::Vector2d next = (distorted - tangential) / radial;
    const double step = (next - p).norm();
    p = next;
    if (step < 1e-14) break;
  }
  return p;
}

Eigen::Vector2d ProjectToPixel(const formats::CameraCalibration& camera, const Eigen::Vector3d& world) {
  const core::RigidTransform& pose = camera.pose.transform;  // world <- camera
  const Eigen::Vector3d c = pose.rotation.transpose() * (world - pose.translation);
  const Eigen::Vector2d d = Distort(camera.distortion, Eigen::Vector2d(c.x() / c.z(), c.y() / c.z()));
  const formats::Intrinsics& k = camera.intrinsics;
  return {k.fx * d.x() + k.cx, k.fy * d.y() + k.cy};
}

CameraRenderer::CameraRenderer(const MesostructureScene& scene, const formats::RigDescription& rig,
                               CameraRendererOptions options)
    : scene_(scene), rig_(rig), options_(options), calibration_(TrueCalibration(rig)) {
  if (rig.backing.present() && rig.backing.depth_mm < scene.d_max_mm() + formats::kMinBackingClearanceMm) {
    std::ostringstream message;
    message << "camera renderer: the backing of rig " << core::Quoted(rig.name) << " at " << rig.backing.depth_mm
            << " mm lies within " << formats::kMinBackingClearanceMm << " mm of the deepest point of scene "
            << core::Quoted(scene.name()) << " (d_max " << scene.d_max_mm()
            << " mm): use a rig description with a deeper sample.backing.depth_mm";
    throw core::Error(message.str());
  }
  if (options_.samples_per_pixel_side < 1 || options_.samples_per_pixel_side > 16) {
    throw core::Error("camera renderer: samples per pixel side must be 1..16");
  }
  if (const auto board = calibration::RigCalibrationBoard(rig)) board_print_.emplace(*board);
  if (options_.interreflection_rays_per_pixel < 0 || options_.interreflection_rays_per_pixel > 256) {
    throw core::Error("camera renderer: interreflection rays per pixel must be 0..256");
  }
  // Each camera keeps one view's first hits (CachedRender); a rig whose
  // cameras the file format allows may still need more than the machine has.
  std::uint64_t bytes = 0;
  for (std::size_t c = 0; c < rig.cameras.size(); ++c) bytes += FirstHitBytes(static_cast<int>(c));
  core::CheckMemoryFor(bytes, "the first hits of the " + std::to_string(rig.cameras.size()) + " simulated cameras of " +
                                  rig.file.string() + " (cameras[0].image_size: " + FirstHitsText(0) +
                                  "; smaller cameras or a lower --samples-per-pixel-side need less)");
}

std::uint64_t CameraRenderer::FirstHitBytes(int camera) const {
  const formats::CameraDescription& c = rig_.cameras.at(camera);
  const auto n = static_cast<std::uint64_t>(options_.samples_per_pixel_side);
  return static_cast<std::uint64_t>(c.width) * static_cast<std::uint64_t>(c.height) * n * n *
         sizeof(CameraView::StoredSample);
}

std::string CameraRenderer::FirstHitsText(int camera) const {
  const formats::CameraDescription& c = rig_.cameras.at(camera);
  const int n = options_.samples_per_pixel_side;
  return std::to_string(c.width) + " x " + std::to_string(c.height) + " pixels, " + std::to_string(n * n) +
         " rays each";
}

Eigen::Vector3d CameraRenderer::CameraCentre(int camera) const {
  return calibration_.cameras.at(camera).pose.transform.translation;
}

Eigen::Vector3d CameraRenderer::PixelRay(int camera, double u, double v) const {
  const formats::CameraCalibration& c = calibration_.cameras.at(camera);
  const formats::Intrinsics& k = c.intrinsics;
  const Eigen::Vector2d n = Undistort(c.distortion, Eigen::Vector2d((u - k.cx) / k.fx, (v - k.cy) / k.fy));
  return (c.pose.transform.rotation * Eigen::Vector3d(n.x(), n.y(), 1.0)).normalized();
}

double CameraRenderer::SlabExit(const Eigen::Vector3d& p, const Eigen::Vector3d& d) const {
  double t = kInfinity;
  if (d.z() > 0.0) t = -p.z() / d.z();
  if (d.z() < 0.0) t = (-scene_.d_max_mm() - p.z()) / d.z();
  const double half = rig_.sample_size_mm / 2;
  for (int axis = 0; axis < 2; ++axis) {
    if (d[axis] > 0) t = std::min(t, (half - p[axis]) / d[axis]);
    if (d[axis] < 0) t = std::min(t, (-half - p[axis]) / d[axis]);
  }
  return t;
}

ViewSample CameraRenderer::SampleHit(const Eigen::Vector3d& origin_world, const Eigen::Vector3d& dir_world,
                                     double turntable_rad) const {
  ViewSample out;
  const Eigen::Matrix3d to_sample = RotationZ(-turntable_rad);
  const Eigen::Vector3d o = to_sample * origin_world;
  const Eigen::Vector3d d = to_sample * dir_world;
  if (d.z() >= 0.0) return out;  // looks up, away from the table
  const double t0 = -o.z() / d.z();
  Eigen::Vector3d p0 = o + t0 * d;  // on the reference plane
  // Exactly on it: rounding leaves z ~1e-14 off at turntable angles other
  // than multiples of 90 degrees, and a ray starting that far below a top
  // at z = 0 (the flat sample, box tops) misses it.
  p0.z() = 0.0;
  const double half = rig_.sample_size_mm / 2;
  if (std::abs(p0.x()) > half || std::abs(p0.y()) > half) {
    return FlatGreySample(ViewSample::Surface::kTurntable,
                          RotationZ(turntable_rad) * Eigen::Vector3d(p0.x(), p0.y(), 0.0), kTurntableAlbedo);
  }
  // Inside the pocket the ray can go as far as the slab's floor or the
  // pocket's walls, whichever comes first.
  const double t_exit = SlabExit(p0, d);
  // From the reference-plane point, as the ground truth casts (the tracer's
  // precision is relative to the tile, not to the camera distance). The
  // interval is closed, so a floor exactly at z = -d_max (a box's base) is hit.
  const auto hit = scene_.Intersect(p0, d, 0.0, std::max(0.0, t_exit));
  const Eigen::Matrix3d to_world = RotationZ(turntable_rad);
  if (!hit) {
    // Through a hole: on to the pocket's backing board, unless the ray leaves
    // the (straight-walled) pocket first.
    if (!rig_.backing.present()) return out;
    const Eigen::Vector3d floor = p0 + (-rig_.backing.depth_mm / d.z()) * d;
    if (std::abs(floor.x()) > half || std::abs(floor.y()) > half) return out;  // the pocket wall
    return FlatGreySample(ViewSample::Surface::kBacking,
                          to_world * Eigen::Vector3d(floor.x(), floor.y(), -rig_.backing.depth_mm),
                          static_cast<float>(rig_.backing.albedo));
  }
  out.surface = ViewSample::Surface::kSample;
  out.point = (to_world * hit->point).cast<float>();
  out.normal = (to_world * hit->normal).cast<float>();
  out.reflectance = hit->reflectance;
  return out;
}

template <typename HitFunction>
CameraView CameraRenderer::Trace(int camera, double turntable_rad, const HitFunction& first_hit) const {
  const formats::CameraCalibration& c = calibration_.cameras.at(camera);
  const int n = options_.samples_per_pixel_side;
  CameraView view;
  view.camera = camera;
  view.turntable_rad = turntable_rad;
  view.width = c.width;
  view.height = c.height;
  view.samples_per_pixel = n * n;
  try {
    view.samples.resize(static_cast<std::size_t>(c.width) * c.height * n * n);
  } catch (const std::bad_alloc&) {
    core::ThrowOutOfMemory(FirstHitBytes(camera), "the first hits of simulated camera " +
                                                      core::Quoted(rig_.cameras.at(camera).id) + " (" +
                                                      FirstHitsText(camera) + ")");
  }
  const Eigen::Vector3d centre = CameraCentre(camera);
  GlossTable glosses;
  tbb::parallel_for(0, c.height, [&](int y) {
    for (int x = 0; x < c.width; ++x) {
      const std::size_t first = (static_cast<std::size_t>(y) * c.width + x) * view.samples_per_pixel;
      for (int k = 0; k < view.samples_per_pixel; ++k) {
        const Eigen::Vector2d offset = SubPixelOffset(k, n);
        const ViewSample s = first_hit(centre, PixelRay(camera, x + offset.x(), y + offset.y()));
        view.samples[first + k] = {s.surface, glosses.IndexOf(s.reflectance), s.point, s.normal,
                                   s.reflectance.diffuse_albedo};
      }
    }
  });
  view.glosses = glosses.Entries();
  return view;
}

ViewSample CameraView::Sample(std::size_t index) const {
  const StoredSample& stored = samples[index];
  ViewSample s;
  s.surface = stored.surface;
  s.point = stored.point;
  s.normal = stored.normal;
  s.reflectance.diffuse_albedo = stored.diffuse_albedo;
  s.reflectance.specular_albedo = glosses[stored.gloss].specular_albedo;
  s.reflectance.glossy_exponent = glosses[stored.gloss].glossy_exponent;
  return s;
}

CameraView CameraRenderer::TraceSample(int camera, double turntable_rad) const {
  return Trace(camera, turntable_rad, [&](const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) {
    return SampleHit(origin, dir, turntable_rad);
  });
}

ViewSample CameraRenderer::FirstHit(int camera, double turntable_rad, double u, double v) const {
  return SampleHit(CameraCentre(camera), PixelRay(camera, u, v), turntable_rad);
}

CameraView CameraRenderer::TracePlate(int camera, double height_mm, float albedo) const {
  return Trace(camera, 0.0, [&](const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) {
    if (dir.z() >= 0.0 || origin.z() <= height_mm) return ViewSample{};
    Eigen::Vector3d point = origin + ((height_mm - origin.z()) / dir.z()) * dir;
    point.z() = height_mm;
    return FlatGreySample(ViewSample::Surface::kCalibrationPlate, point, albedo);
  });
}

bool CameraRenderer::Lit(const CameraView& view, const ViewSample& s, const Eigen::Vector3d& light) const {
  // The sample and the backing under it lie inside the pocket.
  if (s.surface != ViewSample::Surface::kSample && s.surface != ViewSample::Surface::kBacking) {
    return s.surface != ViewSample::Surface::kNothing;
  }
  const Eigen::Matrix3d to_sample = RotationZ(-view.turntable_rad);
  const Eigen::Vector3d p = to_sample * s.Point();
  const Eigen::Vector3d l = (to_sample * (light - s.Point())).normalized();
  if (l.z() <= 0.0) return false;  // a light at or below the reference plane cannot reach into the pocket
  const double t_top = -p.z() / l.z();
  const double eps = scene_.surface_epsilon_mm();
  if (t_top <= eps) return true;  // already on the reference plane: nothing above it
  const Eigen::Vector3d top = p + t_top * l;
  const double half = rig_.sample_size_mm / 2;
  if (std::abs(top.x()) > half || std::abs(top.y()) > half) return false;  // the pocket wall
  return !scene_.Occluded(p, l, eps, t_top);
}

std::optional<ViewSample> CameraRenderer::BounceHit(const CameraView& view, const ViewSample& s,
                                                    const Eigen::Vector3d& dir) const {
  if (s.surface != ViewSample::Surface::kSample) return std::nullopt;
  const Eigen::Matrix3d to_sample = RotationZ(-view.turntable_rad);
  const Eigen::Vector3d p = to_sample * s.Point();
  const Eigen::Vector3d d = to_sample * dir;
  const double t_exit = SlabExit(p, d);
  const double eps = scene_.surface_epsilon_mm();
  if (!(t_exit > eps)) return std::nullopt;
  const auto hit = scene_.Intersect(p, d, eps, t_exit);
  if (!hit) return std::nullopt;
  const Eigen::Matrix3d to_world = RotationZ(view.turntable_rad);
  ViewSample out;
  out.surface = ViewSample::Surface::kSample;
  out.point = (to_world * hit->point).cast<float>();
  out.normal = (to_world * hit->normal).cast<float>();
  out.reflectance = hit->reflectance;
  return out;
}

core::Image CameraRenderer::RenderLamps(const CameraView& view, double arc_rad,
                                        const std::vector<bool>& lamps_on) const {
  const Eigen::Matrix3d arc = RotationZ(arc_rad);
  struct Lamp {
    Eigen::Vector3d position;
    Eigen::Vector3d intensity;
  };
  std::vector<Lamp> lamps;
  for (std::size_t i = 0; i < lamps_on.size() && i < calibration_.lamps.size(); ++i) {
    if (lamps_on[i]) lamps.push_back({arc * calibration_.lamps[i].position_mm, calibration_.lamps[i].intensity});
  }
  const double gain = ExposureSeconds(rig_.cameras.at(view.camera)) * kSignalPerRadianceSecond;
  const Eigen::Vector3d centre = CameraCentre(view.camera);
  core::Image out(view.width, view.height, 3);
  tbb::parallel_for(0, view.height, [&](int y) {
    for (int x = 0; x < view.width; ++x) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      const std::size_t first = (static_cast<std::size_t>(y) * view.width + x) * view.samples_per_pixel;
      for (int k = 0; k < view.samples_per_pixel; ++k) {
        const ViewSample s = view.Sample(first + k);
        if (s.surface == ViewSample::Surface::kNothing) continue;
        const Eigen::Vector3d point = s.Point(), normal = s.Normal();
        const Eigen::Vector3d to_camera = (centre - point).normalized();
        for (const Lamp& lamp : lamps) {
          const Eigen::Vector3d to_lamp = lamp.position - point;
          const double r2 = to_lamp.squaredNorm();
          const Eigen::Vector3d l = to_lamp / std::sqrt(r2);
          const double n_dot_l = normal.dot(l);
          if (n_dot_l <= 0.0 || !Lit(view, s, lamp.position)) continue;
          const Eigen::Vector3d f = s.reflectance.Evaluate(normal, l, to_camera).cast<double>();
          sum += f.cwiseProduct(lamp.intensity) * (n_dot_l / r2);
        }
      }
      float* px = out.pixel(x, y);
      for (int c = 0; c < 3; ++c) px[c] = static_cast<float>(sum[c] * gain / view.samples_per_pixel);
    }
  });
  return out;
}

LaserPlane CameraRenderer::LaserPlaneAt(int mount, double arc_rad, double tilt_rad) const {
  const formats::LaserMountCalibration& m = calibration_.laser_mounts.at(mount);
  const Eigen::Matrix3d arc = RotationZ(arc_rad);
  const Eigen::Vector3d normal = Eigen::AngleAxisd(tilt_rad, m.tilt_axis.normalized()) * m.plane_normal_at_zero_tilt;
  return {arc * m.source_mm, (arc * normal).normalized()};
}

double CameraRenderer::LaserPeakIrradiance() const {
  return rig_.laser.power * rig_.lamps.intensity.mean() / (rig_.lamps.distance_mm * rig_.lamps.distance_mm);
}

double CameraRenderer::LaserGain(int camera) const {
  return ExposureSeconds(rig_.cameras.at(camera)) * kSignalPerRadianceSecond * LaserPeakIrradiance();
}

struct CameraRenderer::RenderCache {
  double turntable_rad = 0.0;
  std::optional<double> plate_height_mm;
  float plate_albedo = kCalibrationPlateAlbedo;
  CameraView view;
  // The sweep's stripe samples, for the laser at `laser_mount` with the arc
  // at `laser_arc_rad`; empty until the laser is first on, and for a plate.
  std::unique_ptr<LaserSweepRenderer> sweep;
  int laser_mount = 0;
  double laser_arc_rad = 0.0;
};

CameraRenderer::RenderCache& CameraRenderer::CachedRender(const SimulatedRigState& state, int camera) {
  if (camera < 0 || camera >= static_cast<int>(rig_.cameras.size())) {
    throw core::Error("camera renderer: no camera " + std::to_string(camera) + " in rig " + core::Quoted(rig_.name));
  }
  if (cache_.empty()) cache_.resize(rig_.cameras.size());
  std::shared_ptr<RenderCache>& entry = cache_[camera];
  // The white reference is a plate too, of the rig's own albedo.
  std::optional<double> plate_height_mm = state.calibration_plate_height_mm;
  float plate_albedo = kCalibrationPlateAlbedo;
  if (state.white_reference_height_mm) {
    if (!rig_.white_reference) {
      throw core::Error("camera renderer: rig " + core::Quoted(rig_.name) + " has no white_reference");
    }
    plate_height_mm = state.white_reference_height_mm;
    plate_albedo = static_cast<float>(rig_.white_reference->albedo);
  }
  const bool stale = !entry || entry->plate_height_mm != plate_height_mm || entry->plate_albedo != plate_albedo ||
                     (!plate_height_mm && entry->turntable_rad != state.turntable_rad);
  if (stale) {
    entry = std::make_shared<RenderCache>();
    entry->turntable_rad = state.turntable_rad;
    entry->plate_height_mm = plate_height_mm;
    entry->plate_albedo = plate_albedo;
    entry->view =
        plate_height_mm ? TracePlate(camera, *plate_height_mm, plate_albedo) : TraceSample(camera, state.turntable_rad);
  }
  // A laser plate is photographed at one tilt: its frame needs no sweep.
  if (state.laser_on && !plate_height_mm &&
      (!entry->sweep || entry->laser_mount != state.laser_mount || entry->laser_arc_rad != state.light_arc_rad)) {
    entry->sweep = std::make_unique<LaserSweepRenderer>(*this, entry->view, state.laser_mount, state.light_arc_rad,
                                                        kMaxSweptTiltRad);
    entry->laser_mount = state.laser_mount;
    entry->laser_arc_rad = state.light_arc_rad;
  }
  return *entry;
}

core::Image CameraRenderer::RenderCalibrationBoard(int camera, int holder, double turntable_rad, int channels) const {
  if (!board_print_) throw core::Error("camera renderer: rig " + core::Quoted(rig_.name) + " has no calibration_board");
  const formats::CalibrationBoardDescription& board = *rig_.calibration_board;
  core::RigidTransform turn;
  turn.parent_frame = "world";
  turn.child_frame = "turntable";
  turn.rotation = RotationZ(turntable_rad);
  const core::RigidTransform world_from_board =
      turn.Compose(BoardOnHolder(board_print_->board(), board.height_mm, board.holder_tilts_rad.at(holder)));
  BoardPhotoOptions photo;
  photo.samples_per_pixel_side = options_.samples_per_pixel_side;
  const formats::CameraCalibration& c = calibration_.cameras.at(camera);
  const auto grid = PhotoGrid(camera, photo.samples_per_pixel_side, {0, 0, c.width, c.height}, PhotoSlot::kBoard);
  const core::Image signal = RenderBoardPhoto(*board_print_, world_from_board, c, photo, grid.get());
  if (channels == 1) return signal;
  core::Image rgb(signal.width(), signal.height(), 3);
  for (std::size_t i = 0; i < signal.size(); ++i) {
    for (int c = 0; c < 3; ++c) rgb.data()[3 * i + c] = signal.data()[i];
  }
  return rgb;
}

std::shared_ptr<const UndistortedGrid> CameraRenderer::PhotoGrid(int camera, int n, PixelRect rect,
                                                                 PhotoSlot slot) const {
  const std::lock_guard<std::mutex> lock(photo_grids_mutex_);
  if (photo_grids_.empty()) photo_grids_.resize(3 * rig_.cameras.size());
  std::shared_ptr<const UndistortedGrid>& kept = photo_grids_.at(3 * camera + static_cast<int>(slot));
  if (!kept || kept->samples_per_pixel_side() != n || !kept->rect().Contains(rect)) {
    kept = std::make_shared<const UndistortedGrid>(calibration_.cameras.at(camera), n, rect);
  }
  return kept;
}

core::Image CameraRenderer::Render(const SimulatedRigState& state, int camera, int channels) {
  if (channels != 1 && channels != 3) {
    throw core::Error("camera renderer: a readout has 1 or 3 channels, not " + std::to_string(channels));
  }
  if (state.calibration_board_holder) {
    return RenderCalibrationBoard(camera, *state.calibration_board_holder, state.turntable_rad, channels);
  }
  if (state.mirror_sphere_placed) {
    const MirrorSpherePhotoOptions photo;
    // One grid for every turntable angle the rig photographs the sphere at
    // (its pixels are computed as photos first need them).
    PixelRect rect = MirrorSpherePixels(rig_, calibration_, camera, state.turntable_rad);
    for (const double angle : rig_.mirror_sphere->turntable_angles_rad) {
      rect = rect.Union(MirrorSpherePixels(rig_, calibration_, camera, angle));
    }
    const auto grid = PhotoGrid(camera, photo.samples_per_pixel_side, rect, PhotoSlot::kSphere);
    const auto centres = PhotoGrid(camera, 1, rect, PhotoSlot::kSphereCentres);
    core::Image rgb = RenderMirrorSpherePhoto(rig_, calibration_, camera, state.turntable_rad, state.light_arc_rad,
                                              state.lamps_on, photo, grid.get(), centres.get());
    return channels == 1 ? core::ChannelMean(std::move(rgb)) : rgb;
  }
  const RenderCache& cached = CachedRender(state, camera);
  const auto stripe_frame = [&] {
    return cached.sweep ? cached.sweep->Frame(state.laser_tilt_rad)
                        : LaserSweepRenderer::SingleFrame(*this, cached.view, state.laser_mount, state.light_arc_rad,
                                                          state.laser_tilt_rad);
  };
  const bool any_lamp = std::find(state.lamps_on.begin(), state.lamps_on.end(), true) != state.lamps_on.end();
  if (!any_lamp && state.laser_on && channels == 1) return stripe_frame();
  core::Image image = any_lamp ? RenderLamps(cached.view, state.light_arc_rad, state.lamps_on)
                               : core::Image(cached.view.width, cached.view.height, channels);
  if (channels == 1) image = core::ChannelMean(std::move(image));
  if (state.laser_on) {
    const core::Image stripe = stripe_frame();
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x) {
        for (int c = 0; c < channels; ++c) image.at(x, y, c) += stripe.at(x, y);
      }
    }
  }
  return image;
}

}  // namespace mesocap::sim
