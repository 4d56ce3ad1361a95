#include "sim/mirror_sphere_renderer.h"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "calibration/rig_frames.h"
#include "sim/camera_renderer.h"
#include "sim/embree_handles.h"

namespace mesocap::sim {

core::CheckResult MirrorSpherePhotoOptions::Check() const {
  if (samples_per_pixel_side < 1 || samples_per_pixel_side > 32) return "samples per pixel side must be 1..32";
  return {};
}

namespace {

constexpr unsigned kMirrorGeometry = 0;
constexpr unsigned kEmitterGeometry = 1;
// Reflected rays start this far (mm) off the mirror, past float rounding of
// coordinates of a few hundred mm.
constexpr float kReflectedRayStart = 1e-3f;

// The sphere and the lamps that are on, in a frame centred on the sphere (so
// that float coordinates keep ~1e-5 mm there).
class MirrorSphereScene {
 public:
  MirrorSphereScene(double radius_mm, const std::vector<Eigen::Vector3d>& emitters, double emitter_radius_mm)
      : emitters_(emitters), radius_(radius_mm), emitter_radius_(emitter_radius_mm) {
    device_.reset(rtcNewDevice(nullptr));
    if (!device_) throw core::Error("Embree: cannot create a device for the mirror sphere");
    scene_.reset(rtcNewScene(device_.get()));
    rtcSetSceneBuildQuality(scene_.get(), RTC_BUILD_QUALITY_HIGH);
    AddSpheres({Eigen::Vector3d::Zero()}, radius_mm, kMirrorGeometry);
    if (!emitters.empty()) AddSpheres(emitters, emitter_radius_mm, kEmitterGeometry);
    rtcCommitScene(scene_.get());
    if (const RTCError error = rtcGetDeviceError(device_.get()); error != RTC_ERROR_NONE) {
      throw core::Error("Embree: cannot build the mirror sphere's scene (error " + std::to_string(error) + ")");
    }
  }

  // The nearest hit past t_near: its geometry and primitive, and t; geometry
  // RTC_INVALID_GEOMETRY_ID when the ray meets nothing.
  struct Hit {
    unsigned geometry = RTC_INVALID_GEOMETRY_ID;
    unsigned primitive = 0;
    double t = 0;
  };
  Hit Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, float t_near) const {
    RTCRayHit rh{};
    rh.ray.org_x = static_cast<float>(origin.x());
    rh.ray.org_y = static_cast<float>(origin.y());
    rh.ray.org_z = static_cast<float>(origin.z());
    rh.ray.dir_x = static_cast<float>(dir.x());
    rh.ray.dir_y = static_cast<float>(dir.y());
    rh.ray.dir_z = static_cast<float>(dir.z());
    rh.ray.tnear = t_near;
    rh.ray.tfar = std::numeric_limits<float>::infinity();
    rh.ray.mask = 0xffffffffu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    rtcIntersect1(scene_.get(), &context, &rh);
    return {rh.hit.geomID, rh.hit.primID, rh.ray.tfar};
  }

  // The same for up to kPacket rays at once (a pixel's sub-pixel rays are
  // nearly parallel: Embree traces them together): ray i for i < count.
  static constexpr int kPacket = 8;
  std::array<Hit, kPacket> Intersect(const Eigen::Vector3d* origins, const Eigen::Vector3d* dirs, int count,
                                     float t_near) const {
    alignas(32) int valid[kPacket];
    alignas(32) RTCRayHit8 rh{};
    for (int i = 0; i < kPacket; ++i) {
      valid[i] = i < count ? -1 : 0;
      const int r = std::min(i, count - 1);
      rh.ray.org_x[i] = static_cast<float>(origins[r].x());
      rh.ray.org_y[i] = static_cast<float>(origins[r].y());
      rh.ray.org_z[i] = static_cast<float>(origins[r].z());
      rh.ray.dir_x[i] = static_cast<float>(dirs[r].x());
      rh.ray.dir_y[i] = static_cast<float>(dirs[r].y());
      rh.ray.dir_z[i] = static_cast<float>(dirs[r].z());
      rh.ray.tnear[i] = t_near;
      rh.ray.tfar[i] = std::numeric_limits<float>::infinity();
      rh.ray.mask[i] = 0xffffffffu;
      rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    }
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    rtcIntersect8(valid, scene_.get(), &context, &rh);
    std::array<Hit, kPacket> hits;
    for (int i = 0; i < count; ++i) hits[i] = {rh.hit.geomID[i], rh.hit.primID[i], rh.ray.tfar[i]};
    return hits;
  }

  const std::vector<Eigen::Vector3d>& emitters() const { return emitters_; }
  double radius() const { return radius_; }
  double emitter_radius() const { return emitter_radius_; }

 private:
  void AddSpheres(const std::vector<Eigen::Vector3d>& centres, double radius, unsigned id) {
    RTCGeometry geometry = rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_SPHERE_POINT);
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                                                 4 * sizeof(float), centres.size()));
    if (vertices == nullptr) {
      rtcReleaseGeometry(geometry);
      throw core::Error("Embree: cannot allocate the mirror sphere's scene");
    }
    for (std::size_t i = 0; i < centres.size(); ++i) {
      for (int k = 0; k < 3; ++k) vertices[4 * i + k] = static_cast<float>(centres[i][k]);
      vertices[4 * i + 3] = static_cast<float>(radius);
    }
    rtcCommitGeometry(geometry);
    rtcAttachGeometryByID(scene_.get(), geometry, id);
    rtcReleaseGeometry(geometry);
  }

  EmbreeDevice device_;
  EmbreeScene scene_;
  std::vector<Eigen::Vector3d> emitters_;
  double radius_ = 0;
  double emitter_radius_ = 0;
};

// Whether a pixel whose centre ray is d0 can show an emitter: false when the
// centre ray meets the sphere away from its outline and its reflection
// passes every emitter by more than the emitter's radius plus four times
// the pixel's spread of reflected rays there (the normal turns by about a
// footprint / R across a pixel; the reflection by twice that). Pixels near
// the outline, where the normal turns fastest, are always rendered.
bool MayReflectAnEmitter(const MirrorSphereScene& scene, const Eigen::Vector3d& origin, const Eigen::Vector3d& d0,
                         double footprint) {
  const MirrorSphereScene::Hit hit = scene.Intersect(origin, d0, 0.0f);
  if (hit.geometry != kMirrorGeometry) return true;
  const Eigen::Vector3d point = origin + hit.t * d0;
  const Eigen::Vector3d normal = point.normalized();
  if (-d0.dot(normal) < 0.3) return true;
  const Eigen::Vector3d reflected = d0 - 2.0 * d0.dot(normal) * normal;
  const double spread = 4.0 * 2.0 * footprint / (scene.radius() * -d0.dot(normal));
  for (const Eigen::Vector3d& e : scene.emitters()) {
    const Eigen::Vector3d to_emitter = e - point;
    const double past = to_emitter.cross(reflected).norm();
    if (to_emitter.dot(reflected) > 0 && past < scene.emitter_radius() + to_emitter.norm() * spread) return true;
  }
  return false;
}

}  // namespace

PixelRect MirrorSpherePixels(const formats::RigDescription& rig, const formats::Calibration& truth, int camera,
                             double turntable_rad) {
  if (!rig.mirror_sphere) throw core::Error("camera renderer: rig " + core::Quoted(rig.name) + " has no mirror_sphere");
  const formats::MirrorSphereDescription& sphere = *rig.mirror_sphere;
  const formats::CameraCalibration& cam = truth.cameras.at(camera);
  const Eigen::Vector3d centre = calibration::WorldFromSample(truth.turntable, turntable_rad)
                                     .Apply(Eigen::Vector3d(sphere.offset_mm, 0, sphere.centre_height_mm));
  const Eigen::Vector3d origin = cam.pose.transform.translation - centre;
  const formats::Intrinsics& k = cam.intrinsics;
  // A square about the sphere's image, half again as wide as the sphere seen
  // from its nearest point plus 4 pixels, so that it holds every pixel the
  // photo's test keeps (lens distortion changes the scale by far less),
  // without undistorting the whole image's rays.
  const Eigen::Vector2d middle = ProjectToPixel(cam, centre);
  const double half = 1.5 * sphere.radius_mm * std::max(k.fx, k.fy) / (origin.norm() - sphere.radius_mm) + 4.0;
  const auto clamp = [](double v, int size) { return std::clamp(static_cast<int>(v), 0, size); };
  return {clamp(std::floor(middle.x() - half), cam.width), clamp(std::floor(middle.y() - half), cam.height),
          clamp(std::ceil(middle.x() + half) + 1, cam.width), clamp(std::ceil(middle.y() + half) + 1, cam.height)};
}

core::Image RenderMirrorSpherePhoto(const formats::RigDescription& rig, const formats::Calibration& truth, int camera,
                                    double turntable_rad, double arc_rad, const std::vector<bool>& lamps_on,
                                    const MirrorSpherePhotoOptions& options, const UndistortedGrid* grid,
                                    const UndistortedGrid* centres) {
  core::ThrowIfInvalid(options.Check(), "mirror sphere photo");
  if (!rig.mirror_sphere) throw core::Error("camera renderer: rig " + core::Quoted(rig.name) + " has no mirror_sphere");
  const formats::MirrorSphereDescription& sphere = *rig.mirror_sphere;
  const formats::CameraCalibration& cam = truth.cameras.at(camera);
  const Eigen::Vector3d centre = calibration::WorldFromSample(truth.turntable, turntable_rad)
                                     .Apply(Eigen::Vector3d(sphere.offset_mm, 0, sphere.centre_height_mm));

  // Emitter radiance L = I / (pi r^2) per lamp on (seen in the mirror times
  // its reflectance); signal = radiance x exposure x the cameras' gain.
  const double r_e = rig.lamps.emitter_radius_mm;
  const double to_signal =
      rig.cameras.at(camera).exposure_us * 1e-6 * kSignalPerRadianceSecond / (std::numbers::pi * r_e * r_e);
  const auto reflectance = static_cast<float>(sphere.reflectance);
  std::vector<Eigen::Vector3d> emitters;
  std::vector<Eigen::Vector3f> emitter_signal;
  for (std::size_t i = 0; i < lamps_on.size() && i < truth.lamps.size(); ++i) {
    if (!lamps_on[i]) continue;
    emitters.push_back(calibration::LightArcPointToWorld(truth.light_arc, arc_rad, truth.lamps[i].position_mm) -
                       centre);
    emitter_signal.push_back((to_signal * truth.lamps[i].intensity).cast<float>());
  }
  const MirrorSphereScene scene(sphere.radius_mm, emitters, r_e);

  const Eigen::Vector3d origin = cam.pose.transform.translation - centre;
  const Eigen::Matrix3d& rotation = cam.pose.transform.rotation;
  const formats::Intrinsics& k = cam.intrinsics;
  const int n = options.samples_per_pixel_side;
  core::Image signal(cam.width, cam.height, 3);
  const PixelRect pixels = MirrorSpherePixels(rig, truth, camera, turntable_rad);
  const auto [x0, y0, x1, y1] = pixels;
  const auto covers = [&](const UndistortedGrid* g, int side) {
    return !g || (g->samples_per_pixel_side() == side && g->rect().Contains(pixels));
  };
  if (!covers(grid, n) || !covers(centres, 1)) {
    throw core::Error("mirror sphere photo: an undistorted grid does not cover the sphere's pixels");
  }
  tbb::parallel_for(y0, y1, [&](int y) {
    for (int x = x0; x < x1; ++x) {
      // Only pixels whose centre ray passes within two footprints of the
      // sphere can see it; the rest of the rig is dark.
      const Eigen::Vector2d m0 = centres ? centres->Pixel(x, y)[0] : UndistortedGrid::Compute(cam, 1, x, y, 0);
      const Eigen::Vector3d d0 = (rotation * Eigen::Vector3d(m0.x(), m0.y(), 1.0)).normalized();
      const double along = -origin.dot(d0);
      if (along <= 0) continue;
      const double footprint = along / std::min(k.fx, k.fy);
      if ((origin + along * d0).norm() > sphere.radius_mm + 2.0 * footprint) continue;
      if (!MayReflectAnEmitter(scene, origin, d0, footprint)) continue;
      Eigen::Vector3f sum = Eigen::Vector3f::Zero();
      const Eigen::Vector2d* samples = grid ? grid->Pixel(x, y) : nullptr;
      for (int first_s = 0; first_s < n * n; first_s += MirrorSphereScene::kPacket) {
        const int count = std::min(MirrorSphereScene::kPacket, n * n - first_s);
        std::array<Eigen::Vector3d, MirrorSphereScene::kPacket> origins, dirs, points, reflected;
        for (int i = 0; i < count; ++i) {
          const int s = first_s + i;
          const Eigen::Vector2d m = samples ? samples[s] : UndistortedGrid::Compute(cam, n, x, y, s);
          origins[i] = origin;
          dirs[i] = (rotation * Eigen::Vector3d(m.x(), m.y(), 1.0)).normalized();
        }
        const auto first = scene.Intersect(origins.data(), dirs.data(), count, 0.0f);
        // The mirror's hits, reflected, make the second packet.
        std::array<int, MirrorSphereScene::kPacket> bounced;
        int bounces = 0;
        for (int i = 0; i < count; ++i) {
          if (first[i].geometry != kMirrorGeometry) continue;
          const Eigen::Vector3d& d = dirs[i];
          points[bounces] = origin + first[i].t * d;
          const Eigen::Vector3d normal = points[bounces].normalized();
          reflected[bounces] = d - 2.0 * d.dot(normal) * normal;
          bounced[bounces++] = i;
        }
        std::array<MirrorSphereScene::Hit, MirrorSphereScene::kPacket> second{};
        if (bounces > 0) second = scene.Intersect(points.data(), reflected.data(), bounces, kReflectedRayStart);
        // Added in the order of the samples.
        for (int i = 0, b = 0; i < count; ++i) {
          if (first[i].geometry == kEmitterGeometry) {
            sum += emitter_signal[first[i].primitive];
          } else if (first[i].geometry == kMirrorGeometry) {
            const MirrorSphereScene::Hit& hit = second[b++];
            if (hit.geometry == kEmitterGeometry) sum += reflectance * emitter_signal[hit.primitive];
          }
        }
      }
      float* px = signal.pixel(x, y);
      for (int c = 0; c < 3; ++c) px[c] = sum[c] / static_cast<float>(n * n);
    }
  });
  return signal;
}

}  // namespace mesocap::sim
