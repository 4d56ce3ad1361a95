#include "sim/camera_sensor.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <optional>
#include <vector>

namespace mesocap::sim {
namespace {

// Below this mean the shot noise is drawn exactly (Poisson); above it, by
// the normal approximation.
constexpr double kExactPoissonBelowElectrons = 100.0;
// Below this mean the Poisson draw is by inversion (sequential search: ~mean
// + 1 steps; std::poisson_distribution's set-up per value cost 100 ns, and a
// sweep frame's stripe tails are ~60000 faint values), and a draw of no
// electron reads the dark table.
constexpr double kInversionBelowElectrons = 12.0;

// The code a zero signal reads (read noise alone, rounded, clamped at 0) by
// inverse transform of one 64-bit draw: code k where the draw lies between
// the (k-1)-th and k-th cumulative thresholds. Most of a laser-sweep frame
// is dark, and a normal draw per value cost 20x the rest of the frame; this
// is the same distribution, exact to 2^-64, for a draw and a table look-up
// (the draw's top 10 bits name the code, except in the few buckets that a
// threshold cuts, which compare).
class DarkCodeTable {
 public:
  DarkCodeTable(double read_noise_codes, double max_code) {
    for (int k = 0; k < kMaxCodes + 1 && k <= max_code; ++k) values_[k] = static_cast<float>(k / max_code);
    if (read_noise_codes > 0.0) {
      // P(code > k) = 1 - Phi((k + 1/2) / sigma); stop where it is below 2^-64.
      for (int k = 0; k < kMaxCodes && k < max_code; ++k) {
        const double above = 0.5 * std::erfc((k + 0.5) / (read_noise_codes * std::numbers::sqrt2));
        // above < 1/2, so above 2^64 fits; the threshold is 2^64 - above 2^64,
        // formed without the cancellation of 1 - above.
        const double tail = above * 0x1p64;
        if (!(tail >= 1.0)) break;
        thresholds_[count_++] = std::uint64_t{0} - static_cast<std::uint64_t>(tail);
      }
    }
    for (std::uint64_t b = 0; b < kBuckets; ++b) {
      const std::uint64_t first = b << kBucketShift, last = first + ((std::uint64_t{1} << kBucketShift) - 1);
      const int code = Search(first);
      bucket_code_[b] = static_cast<std::int8_t>(code == Search(last) ? code : -1);
    }
  }
  // Codes above the table's last threshold are left out (their chance is
  // below 2^-64); a read noise so large that the table fills is not dark-fast.
  bool exact() const { return count_ < kMaxCodes; }
  // code / max code, as ApplySensor returns it.
  float Value(std::uint64_t draw) const {
    const int code = bucket_code_[draw >> kBucketShift];
    return values_[code >= 0 ? code : Search(draw)];
  }

 private:
  static constexpr int kMaxCodes = 64;
  static constexpr int kBucketShift = 54;
  static constexpr std::uint64_t kBuckets = std::uint64_t{1} << (64 - kBucketShift);
  int Search(std::uint64_t draw) const {
    int code = 0;
    while (code < count_ && draw >= thresholds_[code]) ++code;
    return code;
  }
  std::uint64_t thresholds_[kMaxCodes] = {};
  int count_ = 0;
  float values_[kMaxCodes + 1] = {};
  std::int8_t bucket_code_[kBuckets] = {};
};

// SplitMix64 (Steele, Lea and Flood 2014): a 64-bit draw a step, in two
// multiplies, for the dark values (std::mt19937_64 took 7 ns a draw here).
class SplitMix64 {
 public:
  explicit SplitMix64(std::uint64_t seed) : state_(seed) {}
  std::uint64_t operator()() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

 private:
  std::uint64_t state_;
};

}  // namespace

core::Image ApplySensor(const core::Image& signal, const formats::CameraDescription& camera, std::mt19937_64& rng,
                        bool noise_on) {
  const double full_well = camera.full_well_electrons;
  const double max_code = MaxCode(camera);
  const double codes_per_electron = max_code / full_well;
  const double read_variance = camera.read_noise_electrons * camera.read_noise_electrons;
  core::Image out(signal.width(), signal.height(), signal.channels());
  // Rows are drawn in parallel, each from its own generator seeded by one
  // draw of `rng` and the row: the same image whatever the threads do.
  const DarkCodeTable dark(camera.read_noise_electrons * codes_per_electron, max_code);
  const bool dark_fast = noise_on && dark.exact();
  const std::uint64_t image_key = rng();
  const std::size_t row_values = static_cast<std::size_t>(signal.width()) * signal.channels();
  tbb::parallel_for(0, signal.height(), [&](int y) {
    const std::uint64_t row_key = image_key ^ (0x9E3779B97F4A7C15ull * static_cast<std::uint64_t>(y + 1));
    SplitMix64 dark_rng(row_key);
    // Seeding a Mersenne twister costs a few microseconds: only rows with
    // light draw from one.
    std::optional<std::mt19937_64> row_twister;
    auto row_rng = [&]() -> std::mt19937_64& {
      if (!row_twister) row_twister.emplace(row_key);
      return *row_twister;
    };
    std::normal_distribution<double> read_noise(0.0, camera.read_noise_electrons);
    std::normal_distribution<double> unit_normal(0.0, 1.0);
    const float* in = signal.data() + y * row_values;
    float* result = out.data() + y * row_values;
    for (std::size_t i = 0; i < row_values; ++i) {
      // Negative signal is not physical (NaN reads as none either).
      if (dark_fast && !(in[i] > 0.0f)) {
        result[i] = dark.Value(dark_rng());
        continue;
      }
      // Anything above full scale saturates below, after the noise (a
      // saturated pixel has no noise).
      double electrons = std::max(0.0, static_cast<double>(in[i])) * full_well;
      if (noise_on) {
        // Far above the full well the pixel saturates whatever the noise; cap
        // the mean so the draw stays finite.
        const double mean = std::min(electrons, 4.0 * full_well);
        if (mean <= 0.0) {
          electrons = read_noise(row_rng());
        } else if (dark_fast && mean < kInversionBelowElectrons) {
          // Poisson by inversion (sequential search from k = 0).
          const double u = static_cast<double>(dark_rng() >> 11) * 0x1p-53;  // [0, 1)
          double p = std::exp(-mean), below = p;
          int shot = 0;
          while (u >= below && shot < 200) {
            ++shot;
            p *= mean / shot;
            below += p;
          }
          if (shot == 0) {  // no electron: the dark code
            result[i] = dark.Value(dark_rng());
            continue;
          }
          electrons = shot + read_noise(row_rng());
        } else if (mean < kExactPoissonBelowElectrons) {
          std::poisson_distribution<std::int64_t> shot(mean);
          electrons = static_cast<double>(shot(row_rng())) + read_noise(row_rng());
        } else {
          // Shot + read noise as one normal draw of variance mean + read^2:
          // the Poisson's skewness 1/sqrt(mean) is below 0.1 here, far under
          // what quantization keeps, and a draw costs a fifth of the exact one.
          electrons = mean + std::sqrt(mean + read_variance) * unit_normal(row_rng());
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
