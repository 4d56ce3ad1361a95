// The simulated camera's sensor: turns the linear signal a FrameRenderer
// forms (fraction of full scale) into what a real camera delivers: photon
// shot noise, read noise, quantization to the camera's bit depth and
// saturation at full scale (the noise and saturation cases of docs/ARCHITECTURE.md
// "How correctness is shown").
#pragma once

#include <cstdint>
#include <initializer_list>
#include <random>

#include "core/image.h"
#include "formats/rig_description.h"

namespace mesocap::sim {

// The sensor's digital range: codes 0 .. 2^bit_depth - 1.
inline double MaxCode(const formats::CameraDescription& camera) {
  return static_cast<double>((std::uint32_t{1} << camera.bit_depth) - 1);
}

// electrons = signal * full_well_electrons; with noise on, Poisson shot
// noise on the electrons plus Gaussian read noise (read_noise_electrons),
// the shot noise drawn exactly below a mean of 100 electrons and by its
// normal approximation above (a zero signal's code, read noise alone, is
// drawn from its exact distribution by one 64-bit draw: most of a sweep
// frame is dark);
// then code = round(electrons / full_well * MaxCode), clamped to
// [0, MaxCode] (saturation). Returns code / MaxCode in [0, 1], the value
// WriteImage stores in a 16-bit file without further rounding loss.
// Deterministic for a given generator state (it takes one draw and seeds a
// generator per row from it, so rows are drawn in parallel).
core::Image ApplySensor(const core::Image& signal, const formats::CameraDescription& camera, std::mt19937_64& rng,
                        bool noise_on);

// A generator for one image, seeded from the run's seed and the image's
// coordinates (step, camera, frame), so every image's noise is the same
// however the capture is ordered, resumed or parallelised.
std::mt19937_64 ImageNoiseGenerator(std::uint64_t seed, std::initializer_list<std::uint64_t> image_coordinates);

}  // namespace mesocap::sim
