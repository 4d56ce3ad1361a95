#include "btf/btf_assembly.h"

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <utility>

#include "btf/btf_rectification.h"
#include "btf/btf_resampling.h"
#include "calibration/camera_rays.h"
#include "calibration/rig_frames.h"
#include "core/angles.h"
#include "core/error.h"
#include "core/image_io.h"
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/rig_description.h"

namespace mesocap::btf {
namespace {

std::string Degrees(const core::SphericalAngles& a) {
  return "(theta " + std::to_string(core::DegreesFromRadians(a.theta)) + ", phi " +
         std::to_string(core::DegreesFromRadians(a.phi)) + ") deg";
}

// Angle in degrees between direction i of `set` and d (sample frame).
double OffsetDeg(const core::SamplingSet& set, int i, const Eigen::Vector3d& d) {
  return core::DegreesFromRadians(std::acos(std::clamp(set.direction(i).dot(d.normalized()), -1.0, 1.0)));
}

// Index of `d` (sample frame) in `set`, and how far it is from it.
int MatchDirection(const core::SamplingSet& set, const Eigen::Vector3d& d, const std::string& what,
                   const BtfCaptureImage& image, double tolerance_deg, double* offset_deg, const std::string& hint) {
  const int i = set.Nearest(d);
  const double offset = OffsetDeg(set, i, d);
  if (offset > tolerance_deg) {
    throw core::Error(image.file.string() + ": its " + what + " direction " + Degrees(core::AnglesFromDirection(d)) +
                      " is " + std::to_string(offset) + " deg from the nearest of the set '" + set.name() +
                      "' (at most " + std::to_string(tolerance_deg) + " deg" + hint + ")");
  }
  *offset_deg = std::max(*offset_deg, offset);
  return i;
}

core::Image ReadCapture(const BtfCaptureImage& image, const formats::CameraCalibration& camera) {
  if (!std::filesystem::is_regular_file(image.file)) throw core::Error(image.file.string() + ": missing BTF image");
  if (image.checksum) core::ExpectFileChecksum(image.file, *image.checksum);
  // 16-bit samples: every value is finite and >= 0 by its encoding.
  return core::ReadImage(image.file, formats::SessionFrameReadOptions(camera.width, camera.height, 3));
}

}  // namespace

core::CheckResult BtfAssemblyOptions::Check() const {
  if (texels.width < 1 || texels.height < 1) return "texture size must be positive";
  if (!(texels.sample_size_mm > 0) || !std::isfinite(texels.sample_size_mm)) return "sample size must be > 0 mm";
  if (views.size() < 1 || lights.size() < 1) return "the view and light sets must not be empty";
  for (double t : exposure_s) {
    if (!(t > 0) || !std::isfinite(t)) return "every camera's exposure must be > 0 s";
  }
  for (double g : signal_per_radiance_second) {
    if (!(g > 0) || !std::isfinite(g)) return "every camera's gain (signal per radiance second) must be > 0";
  }
  if (max_samples_per_side < 1 || max_samples_per_side > 64) return "max samples per side must be 1..64";
  if (!(max_direction_error_deg >= 0)) return "max direction error must be >= 0 deg";
  if (!(ring_tolerance_deg >= 0) || !(ring_tolerance_deg < 10)) return "ring tolerance must be 0..10 deg";
  return {};
}

namespace {

// An image's view and light directions from the sample centre, sample frame.
struct CentreDirections {
  Eigen::Vector3d view;
  Eigen::Vector3d light;
};

// One camera at one turntable angle and the images it took there.
struct CapturedView {
  int camera = 0;
  double turntable_rad = 0.0;
  std::vector<int> images;
};

Eigen::Vector3d LampInWorld(const formats::Calibration& calibration, const BtfCaptureImage& image) {
  return calibration::LightArcPointToWorld(calibration.light_arc, image.arc_rad,
                                           calibration.lamps[image.lamp].position_mm);
}

// T = L / E per texel (header: radiometry) of one rectified image.
core::Image RadiometricTexture(const core::Image& rectified, const BtfCaptureImage& image,
                               const formats::Calibration& calibration, const core::RigidTransform& world_from_sample,
                               const BtfAssemblyOptions& o) {
  const calibration::TexelGrid grid = o.texels;
  const int w = grid.width, h = grid.height;
  const Eigen::Vector3d normal = world_from_sample.rotation.col(2);
  const Eigen::Vector3d lamp = LampInWorld(calibration, image);
  const Eigen::Vector3d intensity = calibration.lamps[image.lamp].intensity;
  const double radiance_per_value = 1.0 / (o.exposure_s[image.camera] * o.signal_per_radiance_second[image.camera]);
  core::Image out(w, h, 3);
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const Eigen::Vector3d p = world_from_sample.Apply(grid.TexelCentre(i, j));
      const Eigen::Vector3d to_lamp = lamp - p;
      const double r2 = to_lamp.squaredNorm();
      const double cos_l = normal.dot(to_lamp) / std::sqrt(r2);
      if (!(cos_l > 1e-6)) throw core::Error(image.file.string() + ": the lamp is at or below the sample plane");
      const float* src = rectified.pixel(i, j);
      float* dst = out.pixel(i, j);
      for (int c = 0; c < 3; ++c) {
        // A lamp with zero intensity in a channel measures nothing there.
        const double irradiance = intensity[c] * cos_l / r2;
        dst[c] = irradiance > 0 ? static_cast<float>(src[c] * radiance_per_value / irradiance) : 0.0f;
      }
    }
  }
  return out;
}

// Per texel (row-major), the direction from the texel's reference-plane
// point to `target` (world), in the sample frame, minus `nominal`.
std::vector<Eigen::Vector3d> TexelOffsets(const Eigen::Vector3d& target, const Eigen::Vector3d& nominal,
                                          const core::RigidTransform& world_from_sample, const BtfAssemblyOptions& o) {
  const calibration::TexelGrid grid = o.texels;
  const int w = grid.width, h = grid.height;
  const Eigen::Matrix3d to_sample = world_from_sample.rotation.transpose();
  std::vector<Eigen::Vector3d> out;
  out.reserve(static_cast<std::size_t>(w) * h);
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      const Eigen::Vector3d p = world_from_sample.Apply(grid.TexelCentre(i, j));
      out.push_back((to_sample * (target - p)).normalized() - nominal);
    }
  }
  return out;
}

// The images placed on the grid: each image's directions matched to the
// nearest of the sets (within max_direction_error_deg), unmeasured lights of
// a view interpolated from its measured ones.
void AssembleOnGrid(const std::vector<BtfCaptureImage>& images, const formats::Calibration& calibration,
                    const BtfAssemblyOptions& o, const std::vector<CentreDirections>& directions,
                    const BtfViewSink& sink, BtfAssemblyReport* r) {
  struct Placed {
    int image = 0;
    int light = 0;
  };
  std::vector<std::vector<Placed>> by_view(o.views.size());
  std::vector<int> view_camera(o.views.size(), -1);
  std::vector<double> view_turntable(o.views.size(), 0.0);
  const std::string hint = "; off-grid captures need resampling (--resample)";
  for (int k = 0; k < static_cast<int>(images.size()); ++k) {
    const BtfCaptureImage& image = images[k];
    const int v = MatchDirection(o.views, directions[k].view, "view", image, o.max_direction_error_deg,
                                 &r->max_view_offset_deg, hint);
    const int l = MatchDirection(o.lights, directions[k].light, "light", image, o.max_direction_error_deg,
                                 &r->max_light_offset_deg, hint);
    if (r->measured[v][l]) {
      throw core::Error(image.file.string() + ": a second image of view " + std::to_string(v) + ", light " +
                        std::to_string(l));
    }
    if (view_camera[v] >= 0 && (view_camera[v] != image.camera || view_turntable[v] != image.turntable_rad)) {
      throw core::Error(image.file.string() + ": view " + std::to_string(v) +
                        " is also seen by another camera or turntable angle");
    }
    view_camera[v] = image.camera;
    view_turntable[v] = image.turntable_rad;
    r->measured[v][l] = true;
    by_view[v].push_back({k, l});
  }
  for (int v = 0; v < o.views.size(); ++v) {
    if (by_view[v].empty()) {
      throw core::Error("BTF assembly: no image shows view " + std::to_string(v) + " " + Degrees(o.views.angles(v)) +
                        " of the set '" + o.views.name() + "'");
    }
  }

  std::vector<calibration::CameraRays> camera_rays;
  for (const formats::CameraCalibration& camera : calibration.cameras) camera_rays.emplace_back(camera);
  const int w = o.texels.width, h = o.texels.height;
  std::mutex report_mutex;
  tbb::parallel_for(0, o.views.size(), [&](int v) {
    const int cam = view_camera[v];
    const core::RigidTransform world_from_sample =
        calibration::WorldFromSample(calibration.turntable, view_turntable[v]);
    const ReferencePlaneRectifier rectifier(calibration.cameras[cam], camera_rays[cam], world_from_sample, o.texels,
                                            o.max_samples_per_side);
    core::Image out(w, h * o.lights.size(), 3);
    for (const Placed& placed : by_view[v]) {
      const BtfCaptureImage& image = images[placed.image];
      const core::Image texture = RadiometricTexture(rectifier.Rectify(ReadCapture(image, calibration.cameras[cam])),
                                                     image, calibration, world_from_sample, o);
      for (int j = 0; j < h; ++j) std::copy_n(texture.pixel(0, j), 3 * w, out.pixel(0, placed.light * h + j));
    }
    // Lights this view never saw: interpolated from the ones it did.
    std::vector<core::SphericalAngles> seen;
    std::vector<int> seen_index;
    for (const Placed& placed : by_view[v]) {
      seen.push_back(o.lights.angles(placed.light));
      seen_index.push_back(placed.light);
    }
    const core::SamplingSet seen_set = core::SamplingSet::FromAngles("measured", seen);
    int filled = 0;
    for (int l = 0; l < o.lights.size(); ++l) {
      if (r->measured[v][l]) continue;
      const core::SamplingSet::Blend blend = seen_set.Interpolate(o.lights.direction(l));
      for (int b = 0; b < blend.count; ++b) {
        const int from = seen_index[blend.index[b]];
        const float weight = static_cast<float>(blend.weight[b]);
        for (int j = 0; j < h; ++j) {
          const float* src = out.pixel(0, from * h + j);
          float* dst = out.pixel(0, l * h + j);
          for (int i = 0; i < 3 * w; ++i) dst[i] += weight * src[i];
        }
      }
      ++filled;
    }
    std::lock_guard lock(report_mutex);
    sink(v, std::move(out));
    r->filled_pairs += filled;
    r->pixels_per_texel[v] = rectifier.min_pixels_per_texel();
    r->max_samples_per_side = std::max(r->max_samples_per_side, rectifier.samples_per_side_max());
    r->min_pixels_per_texel = std::min(r->min_pixels_per_texel, rectifier.min_pixels_per_texel());
  });
}

// Resampling (btf_resampling.h): first, per captured view, every target
// light from that view's captured lights (each texel with its own light
// directions); then every target view from the captured views (each texel
// with its own view directions). Holds the captured views' light-resampled
// images (one BTF view image each) besides the output.
void AssembleResampled(const std::vector<BtfCaptureImage>& images, const formats::Calibration& calibration,
                       const BtfAssemblyOptions& o, const std::vector<CentreDirections>& directions,
                       const BtfViewSink& sink, BtfAssemblyReport* r) {
  const double tolerance = core::RadiansFromDegrees(o.max_direction_error_deg);
  std::vector<CapturedView> captured;
  for (int k = 0; k < static_cast<int>(images.size()); ++k) {
    auto it = std::find_if(captured.begin(), captured.end(), [&](const CapturedView& c) {
      return c.camera == images[k].camera && c.turntable_rad == images[k].turntable_rad;
    });
    if (it == captured.end()) it = captured.insert(captured.end(), {images[k].camera, images[k].turntable_rad, {}});
    it->images.push_back(k);
  }
  // Which target pairs an image lies on (within the tolerance): measured.
  for (int k = 0; k < static_cast<int>(images.size()); ++k) {
    const int v = o.views.Nearest(directions[k].view), l = o.lights.Nearest(directions[k].light);
    const double dv = OffsetDeg(o.views, v, directions[k].view), dl = OffsetDeg(o.lights, l, directions[k].light);
    r->max_view_offset_deg = std::max(r->max_view_offset_deg, dv);
    r->max_light_offset_deg = std::max(r->max_light_offset_deg, dl);
    if (dv <= o.max_direction_error_deg && dl <= o.max_direction_error_deg) r->measured[v][l] = true;
  }
  std::vector<Eigen::Vector3d> view_centres;
  for (const CapturedView& c : captured) view_centres.push_back(directions[c.images.front()].view);
  const CapturedDirections captured_views = MakeCapturedDirections("BTF assembly: captured views", view_centres,
                                                                   core::RadiansFromDegrees(o.ring_tolerance_deg));
  const int w = o.texels.width, h = o.texels.height;
  const std::size_t texels = static_cast<std::size_t>(w) * h;
  std::vector<calibration::CameraRays> camera_rays;
  for (const formats::CameraCalibration& camera : calibration.cameras) camera_rays.emplace_back(camera);

  // Stage 1: per captured view, all target lights.
  std::vector<core::Image> resampled(captured.size());
  std::vector<double> captured_pixels_per_texel(captured.size());
  std::vector<std::vector<Eigen::Vector3d>> view_offsets(captured.size());
  std::mutex report_mutex;
  tbb::parallel_for(0, static_cast<int>(captured.size()), [&](int c) {
    const CapturedView& view = captured[c];
    const core::RigidTransform world_from_sample =
        calibration::WorldFromSample(calibration.turntable, view.turntable_rad);
    const ReferencePlaneRectifier rectifier(calibration.cameras[view.camera], camera_rays[view.camera],
                                            world_from_sample, o.texels, o.max_samples_per_side);
    std::vector<Eigen::Vector3d> light_centres;
    for (int k : view.images) light_centres.push_back(directions[k].light);
    const CapturedDirections lights = MakeCapturedDirections(
        "BTF assembly: lights of camera " + calibration.cameras[view.camera].id + " at turntable " +
            std::to_string(core::DegreesFromRadians(view.turntable_rad)) + " deg",
        light_centres, core::RadiansFromDegrees(o.ring_tolerance_deg));
    std::vector<core::Image> textures;
    std::vector<std::vector<Eigen::Vector3d>> light_offsets;
    for (int b = 0; b < static_cast<int>(view.images.size()); ++b) {
      const BtfCaptureImage& image = images[view.images[b]];
      textures.push_back(RadiometricTexture(rectifier.Rectify(ReadCapture(image, calibration.cameras[view.camera])),
                                            image, calibration, world_from_sample, o));
      if (o.per_texel_directions) {
        light_offsets.push_back(
            TexelOffsets(LampInWorld(calibration, image), lights.nominal.direction(b), world_from_sample, o));
      }
    }
    view_offsets[c] = TexelOffsets(calibration.cameras[view.camera].pose.transform.translation,
                                   captured_views.nominal.direction(c), world_from_sample, o);
    core::Image& out = resampled[c];
    out = core::Image(w, h * o.lights.size(), 3);
    int extrapolated = 0;
    for (int l = 0; l < o.lights.size(); ++l) {
      const double theta = o.lights.angles(l).theta;
      extrapolated += theta > lights.last_ring_theta + tolerance || theta < lights.first_ring_theta - tolerance;
      for (std::size_t t = 0; t < texels; ++t) {
        const core::SamplingSet::Blend blend = ResampleBlend(lights.nominal, o.lights.direction(l), [&](int b) {
          return o.per_texel_directions ? light_offsets[b][t] : lights.offset[b];
        });
        float* dst = out.pixel(static_cast<int>(t % w), l * h + static_cast<int>(t / w));
        for (int b = 0; b < blend.count; ++b) {
          const float* src = textures[blend.index[b]].data() + 3 * t;
          for (int ch = 0; ch < 3; ++ch) dst[ch] += static_cast<float>(blend.weight[b]) * src[ch];
        }
      }
    }
    captured_pixels_per_texel[c] = rectifier.min_pixels_per_texel();
    std::lock_guard lock(report_mutex);
    r->extrapolated_lights = std::max(r->extrapolated_lights, extrapolated);
    r->max_samples_per_side = std::max(r->max_samples_per_side, rectifier.samples_per_side_max());
    r->min_pixels_per_texel = std::min(r->min_pixels_per_texel, rectifier.min_pixels_per_texel());
  });

  // Stage 2: every target view from the captured views.
  for (int v = 0; v < o.views.size(); ++v) {
    r->pixels_per_texel[v] = captured_pixels_per_texel[captured_views.nominal.Nearest(o.views.direction(v))];
    const double theta = o.views.angles(v).theta;
    r->extrapolated_views +=
        theta > captured_views.last_ring_theta + tolerance || theta < captured_views.first_ring_theta - tolerance;
  }
  std::mutex sink_mutex;
  tbb::parallel_for(0, o.views.size(), [&](int v) {
    core::Image out(w, h * o.lights.size(), 3);
    for (std::size_t t = 0; t < texels; ++t) {
      const core::SamplingSet::Blend blend = ResampleBlend(captured_views.nominal, o.views.direction(v), [&](int c) {
        return o.per_texel_directions ? view_offsets[c][t] : captured_views.offset[c];
      });
      const int i = static_cast<int>(t % w), j = static_cast<int>(t / w);
      for (int l = 0; l < o.lights.size(); ++l) {
        float* dst = out.pixel(i, l * h + j);
        for (int b = 0; b < blend.count; ++b) {
          const float* src = resampled[blend.index[b]].pixel(i, l * h + j);
          for (int ch = 0; ch < 3; ++ch) dst[ch] += static_cast<float>(blend.weight[b]) * src[ch];
        }
      }
    }
    std::lock_guard lock(sink_mutex);
    sink(v, std::move(out));
  });
  for (const auto& row : r->measured)
    for (bool m : row) r->filled_pairs += !m;
}

}  // namespace

void AssembleBtfViews(const std::vector<BtfCaptureImage>& images, const formats::Calibration& calibration,
                      const BtfAssemblyOptions& o, const BtfViewSink& sink, BtfAssemblyReport* report) {
  core::ThrowIfInvalid(o.Check(), "BTF assembly");
  // One exposure and one gain per calibrated camera.
  for (const auto& [per_camera, what] :
       {std::pair{&o.exposure_s, "exposures"}, std::pair{&o.signal_per_radiance_second, "gains"}}) {
    if (per_camera->size() != calibration.cameras.size()) {
      throw core::Error("BTF assembly: " + std::to_string(per_camera->size()) + " " + what + " for " +
                        std::to_string(calibration.cameras.size()) + " calibrated cameras");
    }
  }
  BtfAssemblyReport r;
  r.images = static_cast<int>(images.size());
  r.resampled = o.resample;
  r.measured.assign(o.views.size(), std::vector<bool>(o.lights.size(), false));
  r.pixels_per_texel.assign(o.views.size(), 0.0);
  r.min_pixels_per_texel = std::numeric_limits<double>::infinity();

  std::vector<CentreDirections> directions;
  for (const BtfCaptureImage& image : images) {
    if (image.camera < 0 || image.camera >= static_cast<int>(calibration.cameras.size()) || image.lamp < 0 ||
        image.lamp >= static_cast<int>(calibration.lamps.size())) {
      throw core::Error(image.file.string() + ": camera or lamp index outside the calibration");
    }
    const core::RigidTransform world_from_sample =
        calibration::WorldFromSample(calibration.turntable, image.turntable_rad);
    const Eigen::Matrix3d to_sample = world_from_sample.rotation.transpose();
    const Eigen::Vector3d origin = world_from_sample.translation;
    const Eigen::Vector3d camera_centre = calibration.cameras[image.camera].pose.transform.translation;
    directions.push_back(
        {to_sample * (camera_centre - origin), to_sample * (LampInWorld(calibration, image) - origin)});
  }
  if (o.resample) {
    AssembleResampled(images, calibration, o, directions, sink, &r);
  } else {
    AssembleOnGrid(images, calibration, o, directions, sink, &r);
  }
  for (const auto& row : r.measured)
    for (bool m : row) r.measured_pairs += m;
  // The rig's design, not a fault: a turntable and arc reach only some
  // (view, light) pairs of the sets, and `eval btf` reports the two apart.
  if (r.filled_pairs > 0) {
    spdlog::info(
        "BTF assembly: the rig captures {} of the {} (view, light) pairs; the other {} are interpolated "
        "from each view's captured lights",
        r.measured_pairs, r.filled_pairs + r.measured_pairs, r.filled_pairs);
  }
  if (r.extrapolated_views > 0 || r.extrapolated_lights > 0) {
    spdlog::warn(
        "BTF assembly: {} views and up to {} lights of the sets lie outside the captured polar range and "
        "are extrapolated (the nearest captured ring, constant in theta)",
        r.extrapolated_views, r.extrapolated_lights);
  }
  if (r.min_pixels_per_texel < 1.0) {
    spdlog::warn(
        "BTF assembly: the texture grid is finer than the cameras resolve ({:.2f} pixels per texel at the "
        "most oblique view): detail below a pixel is interpolated, not measured; a coarser --texture-size "
        "keeps every texel resolved",
        r.min_pixels_per_texel);
  }
  if (report) *report = std::move(r);
}

core::FullBtf AssembleBtf(const std::vector<BtfCaptureImage>& images, const formats::Calibration& calibration,
                          const BtfAssemblyOptions& o, BtfAssemblyReport* report) {
  core::FullBtf btf = core::MakeFullBtf(o.texels.width, o.texels.height, o.views, o.lights);
  AssembleBtfViews(
      images, calibration, o, [&](int v, core::Image&& values) { btf.view_images[v] = std::move(values); }, report);
  return btf;
}

std::vector<BtfCaptureImage> SessionBtfImages(const formats::CapturedSession& session,
                                              const formats::Calibration& calibration) {
  const formats::SessionManifest& manifest = session.manifest();
  const std::filesystem::path manifest_file = session.manifest_file();
  std::map<std::string, int> camera_index;
  for (int c = 0; c < static_cast<int>(calibration.cameras.size()); ++c) camera_index[calibration.cameras[c].id] = c;
  std::vector<BtfCaptureImage> images;
  const formats::RigDescription rig = formats::ParseRigDescription(manifest.rig, manifest_file);
  for (std::size_t s = 0; s < manifest.plan.size(); ++s) {
    const formats::PlannedStep& step = manifest.plan[s];
    if (step.kind != formats::StepKind::kBtfImage || !session.IsDone(step.id)) continue;
    const formats::BtfImageStep btf = formats::ReadBtfImageStep(step, s, rig, manifest_file);
    for (const formats::CameraFile& file : btf.files) {
      if (!camera_index.count(file.camera)) {
        throw core::FormatError(manifest_file, "plan step " + step.id + ".files",
                                "camera " + core::Quoted(file.camera) + " not in the calibration");
      }
      images.push_back({session.dir() / file.path, session.RecordedChecksum(file.path), camera_index[file.camera],
                        btf.turntable_rad, btf.arc_rad, btf.lamp});
    }
  }
  if (images.empty()) {
    throw core::Error("BTF assembly: the session " + session.dir().string() + " holds no BTF images");
  }
  return images;
}

}  // namespace mesocap::btf
