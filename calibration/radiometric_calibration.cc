#include "calibration/radiometric_calibration.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "calibration/camera_rays.h"
#include "calibration/rig_frames.h"

namespace mesocap::calibration {
namespace {

// Lamps closer to grazing than this leave the pixel out: cos(theta) in the
// model's denominator would turn a small angle error into a large ratio.
constexpr double kMinCosIncidence = 0.05;

// The product G_c I_l of one channel: mean and standard error of the ratios.
struct Product {
  int camera = 0, lamp = 0, channel = 0;
  double value = 0.0, sigma = 0.0;
};

std::string PairName(const formats::Calibration& geometry, const WhiteReferenceImage& image) {
  return "camera " + geometry.cameras.at(image.camera).id + ", lamp " + geometry.lamps.at(image.lamp).id + " (" +
         image.name + ")";
}

// The three channels' products of one image.
std::vector<Product> MeasureProducts(const formats::Calibration& geometry, const CameraRays& rays, double exposure_s,
                                     const WhiteReferenceImage& image, const RadiometryOptions& o) {
  if (image.image.width() != rays.width() || image.image.height() != rays.height() || image.image.channels() != 3) {
    throw core::Error("radiometric calibration: " + PairName(geometry, image) + ": expected a " +
                      std::to_string(rays.width()) + " x " + std::to_string(rays.height()) + " RGB image, got " +
                      std::to_string(image.image.width()) + " x " + std::to_string(image.image.height()) + " with " +
                      std::to_string(image.image.channels()) + " channels");
  }
  const Eigen::Vector3d lamp =
      LightArcPointToWorld(geometry.light_arc, image.arc_rad, geometry.lamps.at(image.lamp).position_mm);
  const double radius = 0.5 * o.sample_size_mm * o.square_fraction;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum2 = Eigen::Vector3d::Zero();
  int pixels = 0, saturated = 0, dark = 0;
  for (int y = 0; y < rays.height(); ++y) {
    for (int x = 0; x < rays.width(); ++x) {
      Eigen::Vector3d p;
      if (!IntersectHorizontalPlane(rays.centre(), rays.Ray(x, y), o.height_mm, &p)) continue;
      // A disc inside the sample square at any turntable angle.
      if (p.head<2>().norm() > radius) continue;
      const Eigen::Vector3d to_lamp = lamp - p;
      const double r2 = to_lamp.squaredNorm();
      const double cos_theta = to_lamp.z() / std::sqrt(r2);
      if (cos_theta < kMinCosIncidence) continue;
      const float* v = image.image.pixel(x, y);
      const float brightest = std::max({v[0], v[1], v[2]}), darkest = std::min({v[0], v[1], v[2]});
      if (brightest > o.max_signal) {
        ++saturated;
        continue;
      }
      if (darkest < o.min_signal) {
        ++dark;
        continue;
      }
      const double model = exposure_s * o.albedo / std::numbers::pi * cos_theta / r2;
      for (int c = 0; c < 3; ++c) {
        const double ratio = v[c] / model;
        sum[c] += ratio;
        sum2[c] += ratio * ratio;
      }
      ++pixels;
    }
  }
  if (pixels < o.min_pixels) {
    throw core::Error("radiometric calibration: " + PairName(geometry, image) + ": " + std::to_string(pixels) +
                      " usable pixels of the white reference inside the sample square (need " +
                      std::to_string(o.min_pixels) + "; " + std::to_string(saturated) + " saturated, " +
                      std::to_string(dark) + " unlit or below the noise): check the exposure and the lamp");
  }
  std::vector<Product> out;
  for (int c = 0; c < 3; ++c) {
    const double mean = sum[c] / pixels;
    const double variance = std::max(0.0, (sum2[c] - pixels * mean * mean) / std::max(1, pixels - 1));
    out.push_back({image.camera, image.lamp, c, mean, std::sqrt(variance / pixels)});
  }
  return out;
}

// The log-domain fit of the products: x = (log G_c, log I_l,ch), its
// covariance (scaled up by the reduced chi-square when above 1), and the
// fit's figures.
struct ProductFit {
  Eigen::VectorXd x;
  Eigen::MatrixXd covariance;
  double reduced_chi_square = 1.0, relative_residual_rms = 0.0;
};

ProductFit FitProducts(const formats::Calibration& geometry, const std::vector<Product>& products) {
  const int cameras = static_cast<int>(geometry.cameras.size()), lamps = static_cast<int>(geometry.lamps.size());
  // log k = log G_c + log I_l,ch, weighted by 1 / sigma(log k)^2, with the
  // lamps' geometric mean held at the nominal one (a Lagrange multiplier).
  const int n = cameras + 3 * lamps, m = static_cast<int>(products.size());
  Eigen::MatrixXd kkt = Eigen::MatrixXd::Zero(n + 1, n + 1);
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n + 1);
  auto intensity_index = [&](int lamp, int channel) { return cameras + 3 * lamp + channel; };
  std::vector<double> weights;
  for (const Product& p : products) {
    // A sigma of zero (a noiseless image) would be an infinite weight; the
    // floor is far below any sensor's noise.
    const double sigma_log = std::max(p.sigma / p.value, 1e-9);
    const double w = 1.0 / (sigma_log * sigma_log);
    weights.push_back(w);
    const int a = p.camera, b = intensity_index(p.lamp, p.channel);
    const double y = std::log(p.value);
    kkt(a, a) += w;
    kkt(b, b) += w;
    kkt(a, b) += w;
    kkt(b, a) += w;
    rhs[a] += w * y;
    rhs[b] += w * y;
  }
  for (int l = 0; l < lamps; ++l) {
    for (int c = 0; c < 3; ++c) {
      kkt(intensity_index(l, c), n) = kkt(n, intensity_index(l, c)) = 1.0;
      rhs[n] += std::log(geometry.lamps[l].intensity[c]);
    }
  }
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(kkt);
  if (!lu.isInvertible()) throw core::Error("radiometric calibration: the gains and intensities are not determined");
  ProductFit fit;
  fit.x = lu.solve(rhs);
  fit.covariance = lu.inverse().topLeftCorner(n, n);
  const Eigen::VectorXd& x = fit.x;

  double chi2 = 0, relative2 = 0;
  for (int i = 0; i < m; ++i) {
    const Product& p = products[i];
    const double fit = x[p.camera] + x[intensity_index(p.lamp, p.channel)];
    const double r = fit - std::log(p.value);
    chi2 += weights[i] * r * r;
    relative2 += std::pow(std::exp(r) - 1.0, 2);
  }
  const int dof = m - n + 1;
  fit.reduced_chi_square = dof > 0 ? chi2 / dof : 1.0;
  fit.relative_residual_rms = std::sqrt(relative2 / m);
  fit.covariance *= std::max(1.0, fit.reduced_chi_square);
  return fit;
}

}  // namespace

core::CheckResult RadiometryOptions::Check() const {
  if (!(albedo > 0 && albedo <= 1)) return "white reference albedo must be in (0, 1]";
  if (!(sample_size_mm > 0)) return "sample size must be positive";
  if (!(square_fraction > 0 && square_fraction <= 1)) return "square fraction must be in (0, 1]";
  if (!(min_signal >= 0 && min_signal < max_signal && max_signal <= 1)) {
    return "signal window must satisfy 0 <= min_signal < max_signal <= 1";
  }
  if (min_pixels < 2) return "min_pixels must be at least 2";
  return {};
}

RadiometryResult CalibrateRadiometry(const formats::Calibration& geometry, const std::vector<double>& exposure_s,
                                     const std::vector<WhiteReferenceImage>& images, const RadiometryOptions& o) {
  core::ThrowIfInvalid(o.Check(), "radiometric calibration");
  const int cameras = static_cast<int>(geometry.cameras.size()), lamps = static_cast<int>(geometry.lamps.size());
  if (static_cast<int>(exposure_s.size()) != cameras) {
    throw core::Error("radiometric calibration: one exposure per camera is needed");
  }
  for (const formats::LampCalibration& lamp : geometry.lamps) {
    if (!(lamp.intensity.minCoeff() > 0)) {
      throw core::Error("radiometric calibration: lamp " + lamp.id +
                        ": its nominal intensity must be positive in every channel (it sets the scale)");
    }
  }
  // Every (camera, lamp) pair once.
  std::map<std::pair<int, int>, const WhiteReferenceImage*> pairs;
  for (const WhiteReferenceImage& image : images) {
    if (image.camera < 0 || image.camera >= cameras || image.lamp < 0 || image.lamp >= lamps) {
      throw core::Error("radiometric calibration: " + image.name + ": no such camera or lamp in the calibration");
    }
    if (!pairs.emplace(std::make_pair(image.camera, image.lamp), &image).second) {
      throw core::Error("radiometric calibration: " + PairName(geometry, image) + ": a second image of the pair");
    }
  }
  for (int c = 0; c < cameras; ++c) {
    for (int l = 0; l < lamps; ++l) {
      if (!pairs.count({c, l})) {
        throw core::Error("radiometric calibration: no white reference image of camera " + geometry.cameras[c].id +
                          " under lamp " + geometry.lamps[l].id);
      }
    }
  }
  std::vector<CameraRays> rays(geometry.cameras.begin(), geometry.cameras.end());
  std::vector<Product> products;
  for (const auto& [key, image] : pairs) {
    for (const Product& p : MeasureProducts(geometry, rays[key.first], exposure_s[key.first], *image, o)) {
      products.push_back(p);
    }
  }

  ProductFit fit = FitProducts(geometry, products);

  // The lamps' positions' uncertainty, to first order: each lamp moved by
  // its sigma along each axis in turn, its images measured again and the
  // whole fit repeated; the changes add in quadrature (the lamps' errors
  // taken as independent). Moving one lamp moves every gain, through the
  // scale the lamps' mean holds.
  Eigen::VectorXd geometric_variance = Eigen::VectorXd::Zero(fit.x.size());
  for (int l = 0; l < lamps; ++l) {
    const auto& sigma = geometry.lamps[l].uncertainty.position_mm;
    if (!sigma) continue;
    for (int axis = 0; axis < 3; ++axis) {
      if (!((*sigma)[axis] > 0)) continue;
      formats::Calibration moved = geometry;
      moved.lamps[l].position_mm[axis] += (*sigma)[axis];
      std::vector<Product> again;
      for (const Product& p : products) {
        if (p.lamp != l) again.push_back(p);
      }
      for (int c = 0; c < cameras; ++c) {
        for (const Product& p : MeasureProducts(moved, rays[c], exposure_s[c], *pairs.at({c, l}), o)) {
          again.push_back(p);
        }
      }
      geometric_variance += (FitProducts(moved, again).x - fit.x).cwiseAbs2();
    }
  }
  fit.covariance.diagonal() += geometric_variance;
  const Eigen::VectorXd& x = fit.x;
  const Eigen::MatrixXd& covariance = fit.covariance;
  auto intensity_index = [&](int lamp, int channel) { return cameras + 3 * lamp + channel; };

  RadiometryResult result;
  result.reduced_chi_square = fit.reduced_chi_square;
  result.relative_residual_rms = fit.relative_residual_rms;
  result.images_used = static_cast<int>(pairs.size());
  for (int c = 0; c < cameras; ++c) {
    formats::CameraRadiometry r;
    r.signal_per_radiance_second = std::exp(x[c]);
    r.uncertainty.signal_per_radiance_second = r.signal_per_radiance_second * std::sqrt(covariance(c, c));
    result.cameras.push_back(r);
  }
  for (int l = 0; l < lamps; ++l) {
    Eigen::Vector3d intensity, sigma;
    for (int c = 0; c < 3; ++c) {
      const int i = intensity_index(l, c);
      intensity[c] = std::exp(x[i]);
      sigma[c] = intensity[c] * std::sqrt(std::max(0.0, covariance(i, i)));
    }
    result.lamp_ids.push_back(geometry.lamps[l].id);
    result.lamp_intensity.push_back(intensity);
    result.lamp_intensity_sigma.push_back(sigma);
  }
  return result;
}

}  // namespace mesocap::calibration
