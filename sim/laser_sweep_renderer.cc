#include "sim/laser_sweep_renderer.h"

#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <string>

#include "core/error.h"

namespace mesocap::sim {

namespace {

// Beyond 8 sigma the Gaussian is below 1.3e-14: nothing a 16-bit sensor sees.
constexpr double kStripeCutoffSigmas = 8.0;
// Tilt ranges are padded by this (radians) against the rounding of acos and
// of their float storage; Frame still tests the distance itself, so the
// padding changes which samples are visited, never a value.
constexpr double kTiltRangePadding = 1e-6;
// Ranges wider than this (radians: a sweep's stripe covers a point for ~3
// milliradians on the shipped rigs) are not binned: points nearly in every
// plane of the sweep, near the tilt axis.
constexpr double kMaxBinnedSpan = 0.02;
constexpr std::size_t kTiltBins = 1 << 16;

// Calls f(y, pixel, index, sample) for each view sample that sees a
// surface: rows in parallel, a row's samples in pixel order.
template <typename F>
void ForEachSurfaceSample(const CameraView& view, F&& f) {
  tbb::parallel_for(0, view.height, [&](int y) {
    for (int x = 0; x < view.width; ++x) {
      const std::size_t pixel = static_cast<std::size_t>(y) * view.width + x;
      for (int k = 0; k < view.samples_per_pixel; ++k) {
        const std::size_t index = pixel * view.samples_per_pixel + k;
        const ViewSample s = view.Sample(index);
        if (s.surface != ViewSample::Surface::kNothing) f(y, pixel, index, s);
      }
    }
  });
}

// x in [-pi, pi).
double WrapAngle(double x) {
  const double two_pi = 2.0 * std::numbers::pi;
  x = std::fmod(x + std::numbers::pi, two_pi);
  if (x < 0.0) x += two_pi;
  return x - std::numbers::pi;
}

}  // namespace

LaserSweepRenderer::LaserSweepRenderer(const CameraRenderer& renderer, const CameraView& view, int mount,
                                       double arc_rad, double max_tilt_rad, bool light_samples)
    : view_(view),
      max_tilt_(max_tilt_rad),
      width_(view.width),
      height_(view.height),
      sigma_mm_(renderer.rig().laser.stripe_sigma_mm) {
  const formats::LaserMountCalibration& m = renderer.calibration().laser_mounts.at(mount);
  const Eigen::Matrix3d arc = RotationZ(arc_rad);
  source_ = arc * m.source_mm;
  const Eigen::Vector3d axis = arc * m.tilt_axis.normalized();
  n0_ = arc * m.plane_normal_at_zero_tilt;
  k_cross_n0_ = axis.cross(n0_);
  k_k_n0_ = axis.dot(n0_) * axis;
  if (view.samples.size() > kIndexMask) {
    throw core::Error("laser sweep: " + std::to_string(view.samples.size()) + " samples in a view, more than " +
                      std::to_string(kIndexMask) + " can be indexed");
  }
  gain_ = renderer.LaserGain(view.camera);
  camera_centre_ = renderer.CameraCentre(view.camera);
  if (!light_samples) return;
  const formats::CameraCalibration& camera = renderer.calibration().cameras.at(view.camera);
  const int side = renderer.options().samples_per_pixel_side;
  // Per row, the row's lit samples in pixel order, binned in row order.
  std::vector<std::vector<RangedSample>> rows(view.height);
  for (auto& row : rows) row.reserve(static_cast<std::size_t>(view.width) * view.samples_per_pixel);
  ForEachSurfaceSample(view, [&](int y, std::size_t, std::size_t index, const ViewSample& s) {
    const double weight = DirectWeight(renderer, s);
    if (!(weight > 0.0)) return;
    // Sweeps tilt the plane by a few degrees (the stripe must stay on the
    // turntable), which changes the footprint along it by < 1 - cos(tilt).
    const double footprint = StripeFootprintVariance(camera, s, n0_, side);
    AddLit(Stripe(static_cast<std::uint32_t>(index), weight, footprint), s.Point(), &rows[y]);
  });
  const int rays = renderer.options().interreflection_rays_per_pixel;
  if (rays > 0) AddBounces(renderer, view, gain_, rays, &rows);
  Bin(rows);
}

LaserSweepRenderer::LaserSweepRenderer(const CameraRenderer& renderer, const CameraView& view, int mount,
                                       double arc_rad, double max_tilt_rad)
    : LaserSweepRenderer(renderer, view, mount, arc_rad, max_tilt_rad, true) {}

double LaserSweepRenderer::DirectWeight(const CameraRenderer& renderer, const ViewSample& s) const {
  const Eigen::Vector3d l = (source_ - s.Point()).normalized();
  const double n_dot_l = s.Normal().dot(l);
  if (n_dot_l <= 0.0 || !renderer.Lit(view_, s, source_)) return 0.0;
  const Eigen::Vector3d to_camera = (camera_centre_ - s.Point()).normalized();
  // The pixel averages its samples (a box filter).
  return Grey(s.reflectance.Evaluate(s.Normal(), l, to_camera)) * n_dot_l * gain_ / view_.samples_per_pixel;
}

core::Image LaserSweepRenderer::SingleFrame(const CameraRenderer& renderer, const CameraView& view, int mount,
                                            double arc_rad, double tilt_rad) {
  const LaserSweepRenderer plane(renderer, view, mount, arc_rad, std::numbers::pi, false);
  const double cos_t = std::cos(tilt_rad);
  const double sin_t = std::sin(tilt_rad);
  const formats::CameraCalibration& camera = renderer.calibration().cameras.at(view.camera);
  const int side = renderer.options().samples_per_pixel_side;
  const double cutoff2 = kStripeCutoffSigmas * kStripeCutoffSigmas / 2.0;  // as in Frame
  core::Image out(view.width, view.height, 1);
  float* values = out.data();
  ForEachSurfaceSample(view, [&](int, std::size_t pixel, std::size_t, const ViewSample& s) {
    const Distance c = plane.DistanceOf(s.Point());
    const double d = cos_t * c.a + sin_t * c.b + c.c;
    const double footprint = StripeFootprintVariance(camera, s, plane.n0_, side);
    const double exponent = d * d * plane.Stripe(0, 1.0, footprint).inv_two_sigma2;
    if (!(exponent < cutoff2)) return;
    const LitSample lit = plane.Stripe(0, plane.DirectWeight(renderer, s), footprint);
    if (lit.weight > 0.0f) values[pixel] += static_cast<float>(lit.weight * std::exp(-exponent));
  });
  return out;
}

LaserSweepRenderer::Distance LaserSweepRenderer::DistanceOf(const Eigen::Vector3d& point) const {
  const Eigen::Vector3d r = point - source_;
  return {n0_.dot(r) - k_k_n0_.dot(r), k_cross_n0_.dot(r), k_k_n0_.dot(r)};
}

LaserSweepRenderer::LitSample LaserSweepRenderer::Stripe(std::uint32_t source, double weight,
                                                         double footprint_variance) const {
  const double variance = sigma_mm_ * sigma_mm_ + footprint_variance;
  const double sigma = std::sqrt(variance);
  LitSample out;
  out.source = source;
  out.weight = static_cast<float>(weight * sigma_mm_ / sigma);
  out.inv_two_sigma2 = static_cast<float>(1.0 / (2.0 * variance));
  return out;
}

double StripeFootprintVariance(const formats::CameraCalibration& camera, const ViewSample& sample,
                               const Eigen::Vector3d& plane_normal, int samples_per_pixel_side) {
  // P(u, v) = C + z q(u, v) on the tangent plane, q the camera-frame ray
  // (x, y, 1) in the world: dP/du = z / fx (X - (n.X) / (n.Q) Q), Q = (P - C) / z.
  const Eigen::Matrix3d& rotation = camera.pose.transform.rotation;  // world <- camera
  const Eigen::Vector3d offset = sample.Point() - camera.pose.transform.translation;
  const double z = rotation.col(2).dot(offset);
  if (!(z > 0.0)) return 0.0;
  const Eigen::Vector3d q = offset / z;
  const Eigen::Vector3d n = sample.Normal();
  double n_dot_q = n.dot(q);
  const double min_n_dot_q = kMinFootprintCosine * q.norm();
  if (std::abs(n_dot_q) < min_n_dot_q) n_dot_q = n_dot_q < 0.0 ? -min_n_dot_q : min_n_dot_q;
  auto change = [&](const Eigen::Vector3d& axis, double focal) {
    const Eigen::Vector3d dp = z / focal * (axis - n.dot(axis) / n_dot_q * q);
    return plane_normal.dot(dp) / samples_per_pixel_side;
  };
  const double g_u = change(rotation.col(0), camera.intrinsics.fx);
  const double g_v = change(rotation.col(1), camera.intrinsics.fy);
  return (g_u * g_u + g_v * g_v) / 12.0;
}

void LaserSweepRenderer::AddLit(LitSample s, const Eigen::Vector3d& point, std::vector<RangedSample>* lit) const {
  if (!(s.weight > 0.0f)) return;
  const double pi = std::numbers::pi;
  const double cutoff = kStripeCutoffSigmas / std::sqrt(2.0 * s.inv_two_sigma2);
  auto push = [&](const LitSample& entry, double begin, double end) {
    if (end < -max_tilt_ || begin > max_tilt_) return;  // never swept
    lit->push_back({entry, static_cast<float>(begin), static_cast<float>(end)});
  };
  auto add = [&](double begin, double end, Side side) {
    LitSample entry = s;
    entry.source |= static_cast<std::uint32_t>(side) << kIndexBits;
    if (end - begin >= 2.0 * pi) {
      push(entry, -pi, pi);
      return;
    }
    const double span = end - begin;
    begin = WrapAngle(begin);
    end = begin + span;
    // A wide range is checked at every frame: split, both pieces would count.
    if (end <= pi || span > kMaxBinnedSpan) {
      push(entry, begin, end);
    } else {  // across +-pi: two ranges
      push(entry, begin, pi);
      push(entry, -pi, end - 2.0 * pi);
    }
  };
  // d(t) = a cos t + b sin t + c = r cos(t - phi) + c; |d| < cutoff where
  // cos(t - phi) lies in (lo, hi).
  const Distance d = DistanceOf(point);
  const double r = std::hypot(d.a, d.b);
  if (!(r > 1e-12)) {
    if (std::abs(d.c) < cutoff) add(-pi, pi, Side::kAny);
    return;
  }
  const double lo = (-cutoff - d.c) / r, hi = (cutoff - d.c) / r;
  if (lo >= 1.0 || hi <= -1.0) return;  // the plane never comes within the cutoff
  const double phi = std::atan2(d.b, d.a);
  const double near = hi >= 1.0 ? 0.0 : std::acos(hi);  // |t - phi| in (near, far)
  const double far = lo <= -1.0 ? pi : std::acos(lo);
  const double pad = kTiltRangePadding;
  if (near <= pad) {
    add(phi - far - pad, phi + far + pad, Side::kAny);
  } else if (far >= pi - pad) {  // the two ranges meet at phi + pi: one range, so no tilt counts twice
    add(phi + near - pad, phi + 2.0 * pi - near + pad, Side::kAny);
  } else {
    add(phi + near - pad, phi + far + pad, Side::kAfterPhi);
    add(phi - far - pad, phi - near + pad, Side::kBeforePhi);
  }
}

void LaserSweepRenderer::AddBounces(const CameraRenderer& renderer, const CameraView& view, double gain,
                                    int rays_per_pixel, std::vector<std::vector<RangedSample>>* lit_rows) {
  const Eigen::Vector3d centre = renderer.CameraCentre(view.camera);
  // Per row: the bounce samples in pixel order (their bounces_ index counted
  // within the row until the rows are joined), after the direct ones.
  std::vector<std::vector<RangedSample>> rows(height_);
  std::vector<std::vector<BouncePoint>> points(height_);
  tbb::parallel_for(0, height_, [&](int y) {
    for (int x = 0; x < width_; ++x) {
      const std::size_t pixel = static_cast<std::size_t>(y) * width_ + x;
      std::mt19937_64 rng(0x9E3779B97F4A7C15ull * (pixel + 1));
      std::uniform_real_distribution<double> uniform(0.0, 1.0);
      for (int k = 0; k < rays_per_pixel; ++k) {
        const double u1 = uniform(rng), u2 = uniform(rng);
        const ViewSample s = view.Sample(pixel * view.samples_per_pixel + k % view.samples_per_pixel);
        if (s.surface != ViewSample::Surface::kSample) continue;
        // Cosine-distributed about the normal (pdf cos / pi).
        const Eigen::Vector3d n = s.Normal();
        const Eigen::Vector3d t =
            (std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(n).normalized();
        const Eigen::Vector3d b = n.cross(t);
        const double phi = 2.0 * std::numbers::pi * u1;
        const double sin_theta = std::sqrt(u2);
        const Eigen::Vector3d w =
            (std::cos(phi) * sin_theta * t + std::sin(phi) * sin_theta * b + std::sqrt(1.0 - u2) * n).normalized();
        const std::optional<ViewSample> q = renderer.BounceHit(view, s, w);
        if (!q) continue;
        const Eigen::Vector3d l_q = (source_ - q->Point()).normalized();
        const double n_dot_l = q->Normal().dot(l_q);
        if (n_dot_l <= 0.0 || !renderer.Lit(view, *q, source_)) continue;
        const Eigen::Vector3d to_camera = (centre - s.Point()).normalized();
        const Eigen::Vector3f f_s = s.reflectance.Evaluate(s.Normal(), w, to_camera);
        const Eigen::Vector3f f_q = q->reflectance.Evaluate(q->Normal(), l_q, -w);
        const double weight = gain * std::numbers::pi / rays_per_pixel * Grey(f_s.cwiseProduct(f_q)) * n_dot_l;
        if (!(weight > 0.0)) continue;
        // q is lit by the stripe itself, not seen through a pixel: no footprint.
        const std::size_t before = rows[y].size();
        AddLit(Stripe(static_cast<std::uint32_t>(points[y].size()), weight, 0.0), q->Point(), &rows[y]);
        if (rows[y].size() > before) points[y].push_back({q->point, static_cast<std::uint32_t>(pixel)});
      }
    }
  });
  for (int y = 0; y < height_; ++y) {
    const std::size_t offset = bounces_.size();
    if (offset + points[y].size() > kIndexMask) throw core::Error("laser sweep: too many bounce samples to index");
    for (RangedSample& s : rows[y]) {
      const std::uint32_t side = s.lit.source & ~kIndexMask;
      s.lit.source = kBounceBit | side | static_cast<std::uint32_t>(offset + (s.lit.source & kIndexMask));
    }
    bounces_.insert(bounces_.end(), points[y].begin(), points[y].end());
    lit_rows->push_back(std::move(rows[y]));
  }
}

void LaserSweepRenderer::Bin(const std::vector<std::vector<RangedSample>>& rows) {
  // Wide ranges out; the narrow ones are binned in the order they come.
  auto narrow = [](const RangedSample& s) { return s.end - s.begin <= kMaxBinnedSpan; };
  std::size_t narrow_count = 0;
  double last = -std::numeric_limits<double>::infinity();
  first_begin_ = std::numeric_limits<double>::infinity();
  for (const auto& row : rows) {
    for (const RangedSample& s : row) {
      if (!narrow(s)) {
        wide_.push_back(s.lit);
        continue;
      }
      ++narrow_count;
      first_begin_ = std::min(first_begin_, static_cast<double>(s.begin));
      last = std::max(last, static_cast<double>(s.begin));
      max_span_ = std::max(max_span_, static_cast<double>(s.end - s.begin));
    }
  }
  if (narrow_count == 0) return;
  bin_width_ = std::max((last - first_begin_) / (kTiltBins - 1), 1e-12);
  bin_begin_.assign(kTiltBins + 1, 0);
  for (const auto& row : rows) {
    for (const RangedSample& s : row) {
      if (narrow(s)) ++bin_begin_[BinOf(s.begin) + 1];
    }
  }
  for (std::size_t i = 0; i < kTiltBins; ++i) bin_begin_[i + 1] += bin_begin_[i];
  binned_.resize(narrow_count);
  std::vector<std::uint32_t> next(bin_begin_.begin(), bin_begin_.end() - 1);
  for (const auto& row : rows) {
    for (const RangedSample& s : row) {
      if (narrow(s)) binned_[next[BinOf(s.begin)]++] = {s.lit, s.end, PointOf(s.lit)};
    }
  }
}

const Eigen::Vector3f& LaserSweepRenderer::PointOf(const LitSample& s) const {
  const std::uint32_t index = s.source & kIndexMask;
  return (s.source & kBounceBit) != 0 ? bounces_[index].point : view_.samples[index].point;
}

std::size_t LaserSweepRenderer::BinOf(double begin) const {
  const double b = std::floor((begin - first_begin_) / bin_width_);
  return static_cast<std::size_t>(std::clamp(b, 0.0, static_cast<double>(kTiltBins - 1)));
}

core::Image LaserSweepRenderer::Frame(double tilt_rad) const {
  if (!(std::abs(tilt_rad) <= max_tilt_)) {
    throw core::Error("laser sweep: tilt " + std::to_string(tilt_rad) + " rad is beyond the sweep's " +
                      std::to_string(max_tilt_) + " rad");
  }
  const double cos_t = std::cos(tilt_rad);
  const double sin_t = std::sin(tilt_rad);
  const float tilt = static_cast<float>(WrapAngle(tilt_rad));
  core::Image out(width_, height_, 1);
  float* values = out.data();
  const double cutoff2 = kStripeCutoffSigmas * kStripeCutoffSigmas / 2.0;  // (d / sigma)^2 / 2 at the cutoff
  const auto add = [&](const LitSample& s, const Eigen::Vector3f& point) {
    const std::uint32_t index = s.source & kIndexMask;
    const bool bounce = (s.source & kBounceBit) != 0;
    const Distance c = DistanceOf(point.cast<double>());
    const double d = cos_t * c.a + sin_t * c.b + c.c;
    const double exponent = d * d * s.inv_two_sigma2;
    if (!(exponent < cutoff2)) return;
    // sin(t - phi) r = a sin t - b cos t: which of two mirrored ranges t is in.
    const auto side = static_cast<Side>((s.source >> kIndexBits) & 3u);
    const double after = c.a * sin_t - c.b * cos_t;
    if ((side == Side::kAfterPhi && !(after > 0.0)) || (side == Side::kBeforePhi && !(after < 0.0))) return;
    const std::size_t pixel = bounce ? bounces_[index].pixel : index / view_.samples_per_pixel;
    values[pixel] += static_cast<float>(s.weight * std::exp(-exponent));
  };
  for (const LitSample& s : wide_) add(s, PointOf(s));
  if (!binned_.empty()) {
    // Ranges holding the tilt start in [tilt - max span, tilt] (a bin's
    // width of slack for the rounding of the bin index).
    const std::size_t lowest = BinOf(tilt - max_span_ - bin_width_), highest = BinOf(tilt);
    for (std::uint32_t i = bin_begin_[lowest]; i < bin_begin_[highest + 1]; ++i) {
      if (!(tilt > binned_[i].end)) add(binned_[i].lit, binned_[i].point);
    }
  }
  return out;
}

}  // namespace mesocap::sim
