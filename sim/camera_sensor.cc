#include "sim/camera_sensor.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace mesocap::sim {
namespace {

// Below this mean the shot noise is drawn exactly (Poisson); above it, by
// the normal approximation.
constexpr double kExactPoissonBelowElectrons = 100.0;

}  // namespace

Image ApplySensor(const Image& signal, const drivers::CameraDescription& camera, std::mt19937_64& rng,
                  bool noise_on) {
  const double full_well = camera.full_well_electrons;
  const double max_code = MaxCode(camera);
  const double codes_per_electron = max_code / full_well;
  const double read_variance = camera.read_noise_electrons * camera.read_noise_electrons;
  Image out(signal.width(), signal.height(), signal.channels());
  // Rows are drawn in parallel, each from its own generator seeded by one
  // draw of `rng` and the row: the same image whatever the threads do.
  const std::uint64_t image_key = rng();
  const std::size_t row_values = static_cast<std::size_t>(signal.width()) * signal.channels();
  tbb::parallel_for(0, signal.height(), [&](int y) {
    std::mt19937_64 row_rng(image_key ^ (0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(y + 1)));
    std::normal_distribution<double> read_noise(0.0, camera.read_noise_electrons);
    std::normal_distribution<double> unit_normal(0.0, 1.0);
    const float* in = signal.data() + y * row_values;
    float* result = out.data() + y * row_values;
    for (std::size_t i = 0; i < row_values; ++i) {
      // Negative signal is not physical; anything above full scale saturates
      // below, after the noise (a saturated pixel has no noise).
      double electrons = std::max(0.0, static_cast<double>(in[i])) * full_well;
      if (noise_on) {
        // Far above the full well the pixel saturates whatever the noise; cap
        // the mean so the draw stays finite.
        const double mean = std::min(electrons, 4.0 * full_well);
        if (mean < kExactPoissonBelowElectrons) {
          std::poisson_distribution<std::int64_t> shot(mean);
          electrons = (mean > 0.0 ? static_cast<double>(shot(row_rng)) : 0.0) + read_noise(row_rng);
        } else {
          // Shot + read noise as one normal draw of variance mean + read^2:
          // the Poisson's skewness 1/sqrt(mean) is below 0.1 here, far under
          // what quantization keeps, and a draw costs a fifth of the exact one.
          electrons = mean + std::sqrt(mean + read_variance) * unit_normal(row_rng);
        }
      }
      const double code = std::clamp(std::round(electrons * codes_per_electron), 0.0, max_code);
      result[i] = static_cast<float>(code / max_code);
    }
  });
  return out;
}

std::mt19937_64 ImageNoiseGenerator(std::uint64_t seed, std::initializer_list<std::uint64_t> image_coordinates) {
  std::vector<std::uint32_t> words{static_cast<std::uint32_t>(seed), static_cast<std::uint32_t>(seed >> 32)};
  for (const std::uint64_t c : image_coordinates) {
    words.push_back(static_cast<std::uint32_t>(c));
    words.push_back(static_cast<std::uint32_t>(c >> 32));
  }
  std::seed_seq sequence(words.begin(), words.end());
  return std::mt19937_64(sequence);
}

}  // namespace mesocap::sim
