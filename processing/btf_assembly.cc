#include "processing/btf_assembly.h"

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>

#include "core/image_io.h"
#include "core/capture_session.h"
#include "processing/btf_rectification.h"
#include "processing/camera_rays.h"
#include "processing/laser_sweep.h"

namespace mesocap {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;

std::string Degrees(const SphericalAngles& a) {
  return "(theta " + std::to_string(a.theta * kDegPerRad) + ", phi " + std::to_string(a.phi * kDegPerRad) + ") deg";
}

// Index of `d` (sample frame) in `set`, and how far it is from it.
int MatchDirection(const SamplingSet& set, const Eigen::Vector3d& d, const std::string& what,
                   const BtfCaptureImage& image, double tolerance_deg, double* offset_deg) {
  const int i = set.Nearest(d);
  const double offset = std::acos(std::clamp(set.direction(i).dot(d.normalized()), -1.0, 1.0)) * kDegPerRad;
  if (offset > tolerance_deg) {
    throw Error(image.file.string() + ": its " + what + " direction " + Degrees(AnglesFromDirection(d)) + " is " +
                std::to_string(offset) + " deg from the nearest of the set '" + set.name() +
                "' (at most " + std::to_string(tolerance_deg) + " deg; off-grid captures are not resampled)");
  }
  *offset_deg = std::max(*offset_deg, offset);
  return i;
}

Image ReadCapture(const BtfCaptureImage& image, const CameraCalibration& camera) {
  if (!std::filesystem::is_regular_file(image.file)) throw Error(image.file.string() + ": missing BTF image");
  ImageReadOptions o;
  o.expected_width = camera.width;
  o.expected_height = camera.height;
  o.expected_channels = 3;
  Image values = ReadImage(image.file, o);
  for (std::size_t i = 0; i < values.size(); ++i) {
    const float v = values.data()[i];
    if (!std::isfinite(v) || v < 0.0f) {
      const std::size_t p = i / 3;
      throw Error(image.file.string() + ": pixel (" + std::to_string(p % camera.width) + ", " +
                  std::to_string(p / camera.width) + ") channel " + std::to_string(i % 3) + " is " +
                  std::to_string(v) + "; expected a finite value >= 0 (linear signal)");
    }
  }
  return values;
}

}  // namespace

CheckResult BtfAssemblyOptions::Check() const {
  if (texture_width < 1 || texture_height < 1) return "texture size must be positive";
  if (!(sample_size_mm > 0) || !std::isfinite(sample_size_mm)) return "sample size must be > 0 mm";
  if (views.size() < 1 || lights.size() < 1) return "the view and light sets must not be empty";
  for (double t : exposure_s) {
    if (!(t > 0) || !std::isfinite(t)) return "every camera's exposure must be > 0 s";
  }
  if (!(signal_per_radiance_second > 0) || !std::isfinite(signal_per_radiance_second)) {
    return "the cameras' gain (signal per radiance second) must be > 0";
  }
  if (max_samples_per_side < 1 || max_samples_per_side > 64) return "max samples per side must be 1..64";
  if (!(max_direction_error_deg >= 0)) return "max direction error must be >= 0 deg";
  return {};
}

FullBtf AssembleBtf(const std::vector<BtfCaptureImage>& images, const Calibration& calibration,
                    const BtfAssemblyOptions& o, BtfAssemblyReport* report) {
  if (const auto problem = o.Check(); !problem.empty()) throw Error("BTF assembly: " + problem);
  if (o.exposure_s.size() != calibration.cameras.size()) {
    throw Error("BTF assembly: " + std::to_string(o.exposure_s.size()) + " exposures for " +
                std::to_string(calibration.cameras.size()) + " calibrated cameras");
  }
  BtfAssemblyReport r;
  r.images = static_cast<int>(images.size());
  r.measured.assign(o.views.size(), std::vector<bool>(o.lights.size(), false));
  r.min_pixels_per_texel = std::numeric_limits<double>::infinity();

  // Directions of every image, grouped by view.
  struct Placed {
    int image = 0;
    int light = 0;
  };
  std::vector<std::vector<Placed>> by_view(o.views.size());
  std::vector<int> view_camera(o.views.size(), -1);
  std::vector<double> view_turntable(o.views.size(), 0.0);
  for (int k = 0; k < static_cast<int>(images.size()); ++k) {
    const BtfCaptureImage& image = images[k];
    if (image.camera < 0 || image.camera >= static_cast<int>(calibration.cameras.size()) || image.lamp < 0 ||
        image.lamp >= static_cast<int>(calibration.lamps.size())) {
      throw Error(image.file.string() + ": camera or lamp index outside the calibration");
    }
    const RigidTransform world_from_sample = WorldFromSample(calibration.turntable, image.turntable_rad);
    const Eigen::Matrix3d to_sample = world_from_sample.rotation.transpose();
    const Eigen::Vector3d origin = world_from_sample.translation;
    const Eigen::Vector3d camera_centre = calibration.cameras[image.camera].pose.transform.translation;
    const Eigen::Vector3d lamp =
        LightArcPointToWorld(calibration.light_arc, image.arc_rad, calibration.lamps[image.lamp].position_mm);
    const int v = MatchDirection(o.views, to_sample * (camera_centre - origin), "view", image,
                                 o.max_direction_error_deg, &r.max_view_offset_deg);
    const int l = MatchDirection(o.lights, to_sample * (lamp - origin), "light", image, o.max_direction_error_deg,
                                 &r.max_light_offset_deg);
    if (r.measured[v][l]) {
      throw Error(image.file.string() + ": a second image of view " + std::to_string(v) + ", light " +
                  std::to_string(l));
    }
    if (view_camera[v] >= 0 && (view_camera[v] != image.camera || view_turntable[v] != image.turntable_rad)) {
      throw Error(image.file.string() + ": view " + std::to_string(v) +
                  " is also seen by another camera or turntable angle");
    }
    view_camera[v] = image.camera;
    view_turntable[v] = image.turntable_rad;
    r.measured[v][l] = true;
    by_view[v].push_back({k, l});
  }
  for (int v = 0; v < o.views.size(); ++v) {
    if (by_view[v].empty()) {
      throw Error("BTF assembly: no image shows view " + std::to_string(v) + " " +
                  Degrees(o.views.angles(v)) + " of the set '" + o.views.name() + "'");
    }
  }

  std::vector<CameraRays> camera_rays;
  for (const CameraCalibration& camera : calibration.cameras) camera_rays.emplace_back(camera);
  const int w = o.texture_width, h = o.texture_height;
  FullBtf btf = MakeFullBtf(w, h, o.views, o.lights);
  std::mutex report_mutex;
  tbb::parallel_for(0, o.views.size(), [&](int v) {
    const int cam = view_camera[v];
    const RigidTransform world_from_sample = WorldFromSample(calibration.turntable, view_turntable[v]);
    const ReferencePlaneRectifier rectifier(calibration.cameras[cam], camera_rays[cam], world_from_sample, w, h,
                                            o.sample_size_mm, o.max_samples_per_side);
    const Eigen::Vector3d normal = world_from_sample.rotation.col(2);
    Image& out = btf.view_images[v];
    for (const Placed& placed : by_view[v]) {
      const BtfCaptureImage& image = images[placed.image];
      const Image texture = rectifier.Rectify(ReadCapture(image, calibration.cameras[cam]));
      const Eigen::Vector3d lamp =
          LightArcPointToWorld(calibration.light_arc, image.arc_rad, calibration.lamps[image.lamp].position_mm);
      const Eigen::Vector3d intensity = calibration.lamps[image.lamp].intensity;
      const double radiance_per_value = 1.0 / (o.exposure_s[cam] * o.signal_per_radiance_second);
      for (int j = 0; j < h; ++j) {
        for (int i = 0; i < w; ++i) {
          const Eigen::Vector3d p =
              world_from_sample.Apply(ReferencePlaneRectifier::TexelCentre(i, j, w, h, o.sample_size_mm));
          const Eigen::Vector3d to_lamp = lamp - p;
          const double r2 = to_lamp.squaredNorm();
          const double cos_l = normal.dot(to_lamp) / std::sqrt(r2);
          if (!(cos_l > 1e-6)) throw Error(image.file.string() + ": the lamp is at or below the sample plane");
          const float* src = texture.pixel(i, j);
          float* dst = out.pixel(i, placed.light * h + j);
          for (int c = 0; c < 3; ++c) {
            // A lamp with zero intensity in a channel measures nothing there.
            const double irradiance = intensity[c] * cos_l / r2;
            dst[c] = irradiance > 0 ? static_cast<float>(src[c] * radiance_per_value / irradiance) : 0.0f;
          }
        }
      }
    }
    // Lights this view never saw: interpolated from the ones it did.
    std::vector<SphericalAngles> seen;
    std::vector<int> seen_index;
    for (const Placed& placed : by_view[v]) {
      seen.push_back(o.lights.angles(placed.light));
      seen_index.push_back(placed.light);
    }
    const SamplingSet seen_set = SamplingSet::FromAngles("measured", seen);
    int filled = 0;
    for (int l = 0; l < o.lights.size(); ++l) {
      if (r.measured[v][l]) continue;
      const SamplingSet::Blend blend = seen_set.Interpolate(o.lights.direction(l));
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
    r.filled_pairs += filled;
    r.max_samples_per_side = std::max(r.max_samples_per_side, rectifier.samples_per_side_max());
    r.min_pixels_per_texel = std::min(r.min_pixels_per_texel, rectifier.min_pixels_per_texel());
  });
  for (const auto& row : r.measured)
    for (bool m : row) r.measured_pairs += m;
  if (r.filled_pairs > 0) {
    spdlog::warn("BTF assembly: {} of {} (view, light) pairs were not captured by the rig and are interpolated "
                 "from each view's measured lights",
                 r.filled_pairs, r.filled_pairs + r.measured_pairs);
  }
  if (r.min_pixels_per_texel < 1.0) {
    spdlog::warn("BTF assembly: the texture grid is finer than the cameras resolve ({:.2f} pixels per texel at the "
                 "most oblique view): detail below a pixel is interpolated, not measured; a coarser --texture-size "
                 "keeps every texel resolved",
                 r.min_pixels_per_texel);
  }
  if (report) *report = std::move(r);
  return btf;
}

std::vector<BtfCaptureImage> SessionBtfImages(const std::filesystem::path& session, const SessionManifest& manifest,
                                           const Calibration& calibration) {
  std::map<std::string, int> camera_index;
  for (int c = 0; c < static_cast<int>(calibration.cameras.size()); ++c) camera_index[calibration.cameras[c].id] = c;
  constexpr double kRadPerDeg = std::numbers::pi / 180.0;
  std::vector<BtfCaptureImage> images;
  for (const PlannedStep& step : manifest.plan) {
    if (step.kind != StepKind::kBtfImage) continue;
    const auto field = [&](const char* name) {
      if (!step.params.contains(name) || !step.params[name].is_number()) {
        throw FormatError(session / kSessionManifestName, "plan step " + step.id + "." + name, "expected a number");
      }
      return step.params[name].get<double>();
    };
    const double turntable = field("turntable_deg") * kRadPerDeg;
    const double arc = field("arc_deg") * kRadPerDeg;
    const int lamp = static_cast<int>(field("lamp"));
    if (!step.params.contains("files") || !step.params["files"].is_array()) {
      throw FormatError(session / kSessionManifestName, "plan step " + step.id + ".files", "expected a list");
    }
    for (const auto& file : step.params["files"]) {
      const std::string camera = file.value("camera", "");
      const std::string path = file.value("path", "");
      if (!camera_index.count(camera) || !IsSessionPath(path)) {
        throw FormatError(session / kSessionManifestName, "plan step " + step.id + ".files",
                          "camera '" + camera + "' not in the calibration or bad path '" + path + "'");
      }
      images.push_back({session / path, camera_index[camera], turntable, arc, lamp});
    }
  }
  if (images.empty()) throw Error("BTF assembly: the session " + session.string() + " plans no BTF images");
  return images;
}

}  // namespace mesocap
