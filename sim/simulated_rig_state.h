// The state of the simulated rig that determines what a camera records: where
// the stages stand, which lamps and whether the laser are on. The simulated
// devices (sim/simulated_devices.h) change it; a FrameRenderer turns it into
// an image.
#pragma once

#include <atomic>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/image.h"

namespace mesocap::sim {

struct SimulatedRigState {
  double turntable_rad = 0.0;
  double light_arc_rad = 0.0;
  std::vector<bool> lamps_on;
  bool laser_on = false;
  int laser_mount = 0;
  double laser_tilt_rad = 0.0;
  // The flat plate the operator lays over the turntable for the laser-plane
  // calibration (MDF paper Sec. 3.2: the stripe on two planes of different
  // height); while it lies there the cameras see it, not the sample.
  std::optional<double> calibration_plate_height_mm;
  // The calibration board on its holder at this tilt (an index into the rig
  // description's calibration_board.holder_tilts); while it stands there the
  // cameras see it, lit evenly, and not the sample.
  std::optional<int> calibration_board_holder;
  // The white reference of the radiometric calibration, its top at this
  // height: a plate like the one above, of the rig description's albedo.
  std::optional<double> white_reference_height_mm;
  // The rig description's mirror sphere in its cup at the sample centre:
  // while it is there the cameras see it (and only it) against a dark rig.
  bool mirror_sphere_placed = false;
  double clock_s = 0.0;  // simulated time; moves advance it, nobody sleeps
  // Discrete changes so far (a lamp or the laser switched, a stage sent
  // moving or homing, the laser tilted or remounted, something laid on the
  // turntable or taken off): a camera's run of frames of one state ends at
  // each, so a step taken again after a fault images as it did the first time.
  // Atomic: served cameras read it on their own threads.
  std::atomic<std::uint64_t> changes{0};
};

// Forms the image camera `camera` records in `state`: the noiseless linear
// signal in units of full scale at the camera's nominal exposure and 0 dB.
// The sensor model (shot and read noise, quantization; sim/camera_sensor.h)
// comes after the exposure and gain, in SimulatedCamera, so that noise
// follows the settings as on a real sensor. `channels` is the readout's: 3
// (RGB) or 1 (mono: the mean of the RGB signal).
class FrameRenderer {
 public:
  virtual ~FrameRenderer() = default;
  virtual core::Image Render(const SimulatedRigState& state, int camera, int channels) = 0;
};

}  // namespace mesocap::sim
