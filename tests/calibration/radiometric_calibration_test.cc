// The cameras' gains and the lamps' intensities from the white reference,
// against the simulated rig's exact radiometry: the small rig's white
// reference rendered under each lamp (sim/camera_renderer.h), each lamp's
// RGB intensity and each camera's gain then changed by known factors, and
// the sensor's noise applied.
#include "calibration/radiometric_calibration.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "sim/camera_sensor.h"
#include "sim/true_calibration.h"
#include "tests/common/flat_small_rig.h"

namespace mesocap::calibration {
namespace {

// Known departures from the nominal radiometry: per lamp an RGB factor
// (their geometric mean 1, the scale CalibrateRadiometry keeps), per camera
// a gain factor.
const std::vector<Eigen::Vector3d> kLampFactors = {
    {1.15, 1.0, 0.85}, {0.9, 1.05, 1.1}, {1.0, 0.95, 1.05}, {1.1, 1.0, 0.9}};
const std::vector<double> kCameraFactors = {1.0, 1.2, 0.8, 1.05};

class RadiometricCalibrationTest : public testing::FlatSmallRigTest {
 protected:
  RadiometricCalibrationTest() {
    // Scale the lamp factors to a geometric mean of exactly 1.
    double log_sum = 0;
    for (const auto& f : kLampFactors) log_sum += f.array().log().sum();
    lamp_factors_ = kLampFactors;
    for (auto& f : lamp_factors_) f /= std::exp(log_sum / (3.0 * kLampFactors.size()));
    const auto& white = *rig_.white_reference;
    for (std::size_t c = 0; c < rig_.cameras.size(); ++c) {
      for (std::size_t l = 0; l < rig_.lamps.elevations_rad.size(); ++l) {
        sim::SimulatedRigState state;
        state.white_reference_height_mm = white.height_mm;
        state.light_arc_rad = white.arc_angle_rad;
        state.lamps_on.assign(rig_.lamps.elevations_rad.size(), false);
        state.lamps_on[l] = true;
        core::Image signal = renderer_.Render(state, static_cast<int>(c), 3);
        for (int y = 0; y < signal.height(); ++y) {
          for (int x = 0; x < signal.width(); ++x) {
            for (int ch = 0; ch < 3; ++ch) signal.at(x, y, ch) *= kCameraFactors[c] * lamp_factors_[l][ch];
          }
        }
        signals_.push_back({static_cast<int>(c), static_cast<int>(l), white.arc_angle_rad,
                            "c" + std::to_string(c) + "_l" + std::to_string(l), std::move(signal)});
      }
    }
    options_.albedo = white.albedo;
    options_.height_mm = white.height_mm;
    options_.sample_size_mm = rig_.sample_size_mm;
    for (const auto& camera : rig_.cameras) exposure_s_.push_back(camera.exposure_us * 1e-6);
  }

  // The rendered signals through the sensor, with noise seed `seed`.
  std::vector<WhiteReferenceImage> Photographed(std::uint64_t seed) const {
    std::vector<WhiteReferenceImage> images;
    for (const WhiteReferenceImage& s : signals_) {
      std::mt19937_64 rng =
          sim::ImageNoiseGenerator(seed, {static_cast<std::uint64_t>(s.camera), static_cast<std::uint64_t>(s.lamp)});
      WhiteReferenceImage image = s;
      image.image = sim::ApplySensor(s.image, rig_.cameras[s.camera], rng, true);
      images.push_back(std::move(image));
    }
    return images;
  }

  double TrueGain(int camera) const {
    return calibration_.cameras[camera].radiometry->signal_per_radiance_second * kCameraFactors[camera];
  }

  std::vector<Eigen::Vector3d> lamp_factors_;
  std::vector<WhiteReferenceImage> signals_;  // noiseless
  RadiometryOptions options_;
  std::vector<double> exposure_s_;
};

// Within 1 % of the truth, and the sigmas honest over noise seeds: the
// errors divided by the sigmas have an RMS near 1.
TEST_F(RadiometricCalibrationTest, GainsAndIntensitiesWithinTheirSigmasOverNoiseSeeds) {
  double gain_ratio2 = 0, intensity_ratio2 = 0, worst_gain = 0, worst_intensity = 0;
  int gains = 0, intensities = 0;
  constexpr int kSeeds = 8;
  for (int seed = 0; seed < kSeeds; ++seed) {
    const RadiometryResult r = CalibrateRadiometry(calibration_, exposure_s_, Photographed(seed + 1), options_);
    ASSERT_EQ(r.cameras.size(), rig_.cameras.size());
    EXPECT_EQ(r.images_used, 16);
    EXPECT_LT(r.reduced_chi_square, 3.0);
    for (std::size_t c = 0; c < r.cameras.size(); ++c) {
      const double g = r.cameras[c].signal_per_radiance_second, truth = TrueGain(static_cast<int>(c));
      const double sigma = *r.cameras[c].uncertainty.signal_per_radiance_second;
      ASSERT_GT(sigma, 0.0);
      worst_gain = std::max(worst_gain, std::abs(g / truth - 1));
      gain_ratio2 += std::pow((g - truth) / sigma, 2);
      ++gains;
    }
    for (std::size_t l = 0; l < r.lamp_intensity.size(); ++l) {
      for (int ch = 0; ch < 3; ++ch) {
        const double truth = lamp_factors_[l][ch] * calibration_.lamps[l].intensity[ch];
        worst_intensity = std::max(worst_intensity, std::abs(r.lamp_intensity[l][ch] / truth - 1));
        intensity_ratio2 += std::pow((r.lamp_intensity[l][ch] - truth) / r.lamp_intensity_sigma[l][ch], 2);
        ++intensities;
      }
    }
  }
  const double gain_rms = std::sqrt(gain_ratio2 / gains), intensity_rms = std::sqrt(intensity_ratio2 / intensities);
  std::printf("worst relative error: gain %.5f, intensity %.5f; errors / sigma RMS: gain %.2f, intensity %.2f\n",
              worst_gain, worst_intensity, gain_rms, intensity_rms);
  EXPECT_LT(worst_gain, 0.01);
  EXPECT_LT(worst_intensity, 0.01);
  EXPECT_GT(gain_rms, 0.4);
  EXPECT_LT(gain_rms, 2.0);
  EXPECT_GT(intensity_rms, 0.4);
  EXPECT_LT(intensity_rms, 2.0);
}

// The lamp nearest grazing (11.25 degrees of elevation) lights the plate
// weakly and obliquely: its intensities are the least certain, and said so.
TEST_F(RadiometricCalibrationTest, TheGrazingLampIsTheLeastCertain) {
  const RadiometryResult r = CalibrateRadiometry(calibration_, exposure_s_, Photographed(1), options_);
  int least_certain = 0;
  for (std::size_t l = 0; l < r.lamp_intensity.size(); ++l) {
    const double relative = r.lamp_intensity_sigma[l].norm() / r.lamp_intensity[l].norm();
    if (relative > r.lamp_intensity_sigma[least_certain].norm() / r.lamp_intensity[least_certain].norm()) {
      least_certain = static_cast<int>(l);
    }
  }
  EXPECT_EQ(least_certain, 3);  // elevation 11.25 degrees
}

TEST_F(RadiometricCalibrationTest, SaturatedDarkAndMissingImagesAreErrorsNamingThePair) {
  std::vector<WhiteReferenceImage> images = Photographed(1);
  // Ten times the exposure: every pixel of the reference at full scale.
  std::vector<WhiteReferenceImage> saturated = images;
  core::Image& bright = saturated[5].image;
  for (std::size_t i = 0; i < bright.size(); ++i) bright.data()[i] = std::min(1.0f, 10 * bright.data()[i]);
  try {
    CalibrateRadiometry(calibration_, exposure_s_, saturated, options_);
    ADD_FAILURE() << "a saturated image was accepted";
  } catch (const core::Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("camera cam1, lamp lamp1"), std::string::npos) << what;
    EXPECT_NE(what.find("saturated"), std::string::npos) << what;
  }
  // A lamp that did not light: read noise only.
  std::vector<WhiteReferenceImage> dark = images;
  core::Image& unlit = dark[2].image;
  for (std::size_t i = 0; i < unlit.size(); ++i) unlit.data()[i] = 0.0f;
  EXPECT_THROW(CalibrateRadiometry(calibration_, exposure_s_, dark, options_), core::Error);
  std::vector<WhiteReferenceImage> missing(images.begin(), images.end() - 1);
  try {
    CalibrateRadiometry(calibration_, exposure_s_, missing, options_);
    ADD_FAILURE() << "a missing pair was accepted";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("camera cam3 under lamp lamp3"), std::string::npos) << e.what();
  }
  RadiometryOptions bad = options_;
  bad.albedo = 0.0;
  EXPECT_THROW(CalibrateRadiometry(calibration_, exposure_s_, images, bad), core::Error);
}

}  // namespace
}  // namespace mesocap::calibration
