#include "sim/simulated_devices.h"
#include "core/angles.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "drivers/device_error.h"
#include "sim/camera_sensor.h"

namespace mesocap::sim {
namespace {
// A camera that drops every frame would otherwise loop for the whole timeout
// in exposures of a microsecond.
constexpr int kMaxDropsPerGrab = 1000;

double Seconds(std::chrono::milliseconds d) { return static_cast<double>(d.count()) / 1000.0; }

double Wrap(double angle) {
  double a = std::fmod(angle, core::kTwoPi);
  if (a < 0.0) a += core::kTwoPi;
  return a >= core::kTwoPi ? 0.0 : a;  // fmod of -tiny + 2 pi rounds to 2 pi
}

// The signed shorter way from `from` to `to`, in [-pi, pi].
double ShorterWay(double from, double to) { return std::remainder(to - from, core::kTwoPi); }

std::string Range(double min, double max, const char* unit) {
  auto text = [](double v) {
    std::string s = std::to_string(v);
    s.erase(s.find_last_not_of('0') + 1);
    if (s.back() == '.') s.pop_back();
    return s;
  };
  return "[" + text(min) + ", " + text(max) + "] " + unit;
}

}  // namespace

// ---------------------------------------------------------------- camera

SimulatedCamera::SimulatedCamera(const formats::RigDescription& rig, int camera_index,
                                 std::shared_ptr<SimulatedRigState> state, FrameRenderer& renderer,
                                 const FaultPlan& faults, std::uint64_t seed, SensorModel sensor)
    : state_(std::move(state)),
      renderer_(&renderer),
      index_(camera_index),
      description_(rig.cameras.at(camera_index)),
      seed_(seed),
      sensor_(sensor) {
  const formats::CameraDescription& d = rig.cameras.at(camera_index);
  info_.id = d.id;
  info_.model = "mesocap simulated camera";
  info_.sensor_width = d.width;
  info_.sensor_height = d.height;
  info_.bit_depth = d.bit_depth;
  info_.channels = 3;
  reference_exposure_us_ = d.exposure_us;
  settings_.exposure_us = std::clamp(d.exposure_us, kMinExposureUs, kMaxExposureUs);
  drop_frame_ = FaultSchedule(faults, FaultKind::kCameraDropFrame, d.id, seed);
  timeout_ = FaultSchedule(faults, FaultKind::kCameraTimeout, d.id, seed);
  disconnect_ = FaultSchedule(faults, FaultKind::kCameraDisconnect, d.id, seed);
}

void SimulatedCamera::Fail(const std::string& problem) const {
  throw drivers::DeviceError("camera " + info_.id + ": " + problem);
}

void SimulatedCamera::Call() {
  if (!disconnected_ && disconnect_.Fires()) disconnected_ = true;
  if (disconnected_) throw drivers::DisconnectedError("camera " + info_.id + ": disconnected");
}

void SimulatedCamera::SetExposure(double exposure_us) {
  Call();
  if (!(exposure_us >= kMinExposureUs && exposure_us <= kMaxExposureUs)) {
    Fail("exposure " + std::to_string(exposure_us) + " us is outside " + Range(kMinExposureUs, kMaxExposureUs, "us"));
  }
  settings_.exposure_us = exposure_us;
}

void SimulatedCamera::SetGain(double gain_db) {
  Call();
  if (!(gain_db >= 0.0 && gain_db <= kMaxGainDb)) {
    Fail("gain " + std::to_string(gain_db) + " dB is outside " + Range(0.0, kMaxGainDb, "dB"));
  }
  settings_.gain_db = gain_db;
}

void SimulatedCamera::SetRegion(const drivers::CameraRegion& r) {
  Call();
  const int w = info_.sensor_width;
  const int h = info_.sensor_height;
  const std::string sensor = " on the " + std::to_string(w) + " x " + std::to_string(h) + " sensor";
  if (r.x < 0 || r.y < 0 || r.width < 0 || r.height < 0) Fail("region with a negative origin or size" + sensor);
  if (r.width == 0 && r.x != 0) Fail("a full-width region (width 0) starts at x 0");
  if (r.height == 0 && r.y != 0) Fail("a full-height region (height 0) starts at y 0");
  if (r.x >= w || r.width > w - r.x || r.y >= h || r.height > h - r.y) {
    Fail("region " + std::to_string(r.width) + " x " + std::to_string(r.height) + " at (" + std::to_string(r.x) + ", " +
         std::to_string(r.y) + ") is not inside the sensor" + sensor);
  }
  settings_.region = r;
}

void SimulatedCamera::SetPixelFormat(drivers::PixelFormat format) {
  Call();
  settings_.pixel_format = format;
}

void SimulatedCamera::SetTrigger(drivers::TriggerMode mode) {
  Call();
  settings_.trigger = mode;
  pending_triggers_ = 0;  // a trigger given in the old mode exposes nothing
}

void SimulatedCamera::Trigger() {
  Call();
  if (settings_.trigger == drivers::TriggerMode::kSoftware) ++pending_triggers_;
}

drivers::Frame SimulatedCamera::Grab(std::chrono::milliseconds timeout) {
  Call();
  const double timeout_s = std::max(0.0, Seconds(timeout));
  if (settings_.trigger == drivers::TriggerMode::kSoftware) {
    if (pending_triggers_ == 0) {
      state_->clock_s += timeout_s;
      throw drivers::TimeoutError("camera " + info_.id + ": no frame (software trigger mode and no Trigger())");
    }
    --pending_triggers_;
  }
  if (timeout_.Fires()) {
    ++next_sequence_;  // the frame was exposed but never arrived
    state_->clock_s += timeout_s;
    throw drivers::TimeoutError("camera " + info_.id + ": no frame within " + std::to_string(timeout.count()) + " ms");
  }
  const double exposure_s = settings_.exposure_us * 1e-6;
  double waited_s = 0.0;
  for (int drops = 0; drop_frame_.Fires(); ++drops) {
    ++next_sequence_;
    state_->clock_s += exposure_s;
    waited_s += exposure_s;
    if (waited_s > timeout_s || drops + 1 >= kMaxDropsPerGrab) {
      throw drivers::TimeoutError("camera " + info_.id + ": every frame dropped for " +
                                  std::to_string(timeout.count()) + " ms");
    }
  }

  drivers::Frame frame;
  frame.sequence = next_sequence_++;
  frame.timestamp_s = state_->clock_s;
  frame.settings = settings_;
  frame.bit_depth = info_.bit_depth;
  const int channels = settings_.pixel_format == drivers::PixelFormat::kMono ? 1 : info_.channels;
  core::Image full = renderer_->Render(*state_, index_, channels);
  state_->clock_s += exposure_s;
  if (full.width() != info_.sensor_width || full.height() != info_.sensor_height || full.channels() != channels) {
    throw core::Error("camera " + info_.id + ": the frame renderer gave a " + std::to_string(full.width()) + " x " +
                      std::to_string(full.height()) + " x " + std::to_string(full.channels()) + " image for a " +
                      std::to_string(info_.sensor_width) + " x " + std::to_string(info_.sensor_height) + " x " +
                      std::to_string(channels) + " readout");
  }

  const auto& r = settings_.region;
  const int width = r.width == 0 ? info_.sensor_width : r.width;
  const int height = r.height == 0 ? info_.sensor_height : r.height;
  // The renderer's signal is at the description's exposure and 0 dB.
  const double scale = settings_.exposure_us / reference_exposure_us_ * std::pow(10.0, settings_.gain_db / 20.0);
  core::Image signal;
  if (width == info_.sensor_width && height == info_.sensor_height && scale == 1.0) {
    signal = std::move(full);  // the whole sensor at the description's exposure: nothing to cut or scale
  } else {
    signal = core::Image(width, height, channels);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const float* in = full.pixel(r.x + x, r.y + y);
        float* out = signal.pixel(x, y);
        for (int c = 0; c < channels; ++c) out[c] = static_cast<float>(in[c] * scale);
      }
    }
  }
  if (sensor_ == SensorModel::kIdeal) {
    // NaN fails v > 0 and reads as 0.
    for (std::size_t i = 0; i < signal.size(); ++i) {
      const float v = signal.data()[i];
      signal.data()[i] = v > 0.0f ? std::min(v, 1.0f) : 0.0f;
    }
    frame.image = std::move(signal);
  } else {
    const std::uint64_t key = ImagedStateKey();
    const bool same_run = key == last_state_key_ && state_->changes == last_state_changes_;
    repeats_of_state_ = same_run ? repeats_of_state_ + 1 : 0;
    last_state_key_ = key;
    last_state_changes_ = state_->changes;
    std::mt19937_64 rng = ImageNoiseGenerator(seed_, {static_cast<std::uint64_t>(index_), key, repeats_of_state_});
    frame.image = ApplySensor(signal, description_, rng, sensor_ == SensorModel::kNoisy);
  }
  // Values are at most 1 (the top code), so a pixel's channels saturate
  // where their largest is 1: a branch-free pass.
  const float* values = frame.image.data();
  for (std::size_t p = 0; p < static_cast<std::size_t>(width) * height; ++p) {
    float top = values[p * channels];
    for (int c = 1; c < channels; ++c) top = std::max(top, values[p * channels + c]);
    frame.saturated_pixels += top >= 1.0f ? 1 : 0;
  }
  return frame;
}

std::uint64_t SimulatedCamera::ImagedStateKey() const {
  // FNV-1a over the state's values: angles rounded to 1e-9 rad so that the
  // same plan step images the same state bit for bit.
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](std::uint64_t v) {
    for (int b = 0; b < 8; ++b) {
      h ^= (v >> (8 * b)) & 0xff;
      h *= 1099511628211ull;
    }
  };
  auto mix_real = [&mix](double v) { mix(static_cast<std::uint64_t>(std::llround(v * 1e9))); };
  const SimulatedRigState& s = *state_;
  mix_real(s.turntable_rad);
  mix_real(s.light_arc_rad);
  for (bool on : s.lamps_on) mix(on ? 1 : 0);
  mix(s.laser_on ? 1 : 0);
  if (s.laser_on) {
    mix(static_cast<std::uint64_t>(s.laser_mount));
    mix_real(s.laser_tilt_rad);
  }
  mix(s.calibration_plate_height_mm ? 1 : 0);
  if (s.calibration_plate_height_mm) mix_real(*s.calibration_plate_height_mm);
  mix(s.calibration_board_holder ? 1 + static_cast<std::uint64_t>(*s.calibration_board_holder) : 0);
  mix(s.white_reference_height_mm ? 1 : 0);
  if (s.white_reference_height_mm) mix_real(*s.white_reference_height_mm);
  mix(s.mirror_sphere_placed ? 1 : 0);
  mix_real(settings_.exposure_us);
  mix_real(settings_.gain_db);
  const auto& r = settings_.region;
  for (int v : {r.x, r.y, r.width, r.height}) mix(static_cast<std::uint64_t>(v));
  return h;
}

// ---------------------------------------------------------------- stages

SimulatedRotaryStage::SimulatedRotaryStage(const formats::RigDescription& rig, Axis axis,
                                           std::shared_ptr<SimulatedRigState> state, const FaultPlan& faults,
                                           std::uint64_t seed)
    : state_(std::move(state)),
      axis_(axis),
      speed_(axis == Axis::kTurntable ? rig.turntable.speed_rad_per_s : rig.light_arc.speed_rad_per_s) {
  const std::string device(axis == Axis::kTurntable ? kTurntableId : kLightArcId);
  stall_ = FaultSchedule(faults, FaultKind::kStageStall, device, seed);
  timeout_ = FaultSchedule(faults, FaultKind::kStageTimeout, device, seed);
  physical_ = Wrap(StateAngle());
  target_ = physical_;
}

std::string SimulatedRotaryStage::id() const {
  return std::string(axis_ == Axis::kTurntable ? kTurntableId : kLightArcId);
}

double& SimulatedRotaryStage::StateAngle() const {
  return axis_ == Axis::kTurntable ? state_->turntable_rad : state_->light_arc_rad;
}

void SimulatedRotaryStage::Fail(const std::string& problem) const { throw drivers::DeviceError(id() + ": " + problem); }

bool SimulatedRotaryStage::StalledAt(double t) const {
  return move_ && move_->stall_after_s >= 0.0 && t >= move_->start_s + move_->stall_after_s;
}

double SimulatedRotaryStage::PhysicalAt(double t) const {
  if (!move_) return physical_;
  double elapsed = std::max(0.0, t - move_->start_s);
  if (move_->stall_after_s >= 0.0) elapsed = std::min(elapsed, move_->stall_after_s);
  const double fraction = move_->duration_s > 0.0 ? std::min(1.0, elapsed / move_->duration_s) : 1.0;
  return Wrap(move_->from + move_->delta * fraction);
}

void SimulatedRotaryStage::Update() {
  const double t = state_->clock_s;
  if (StalledAt(t)) homed_ = false;  // it lost steps: its count is wrong from here on
  StateAngle() = PhysicalAt(t);
}

SimulatedRotaryStage::Move SimulatedRotaryStage::Plan(double from, double delta, double duration_s) {
  Move m;
  m.from = from;
  m.delta = delta;
  m.start_s = state_->clock_s;
  m.duration_s = duration_s;
  // Both schedules count every move, so one kind's firing does not shift the other.
  const bool stall = stall_.Fires();
  const bool timeout = timeout_.Fires();
  if (stall) m.stall_after_s = stall_.Uniform() * m.duration_s;
  m.timeout_fault = timeout && !stall;
  return m;
}

void SimulatedRotaryStage::Home() {
  Update();
  ++state_->changes;
  const double t = state_->clock_s;
  const double from = PhysicalAt(t);
  move_.reset();
  physical_ = from;
  homed_ = false;
  const double delta = ShorterWay(from, 0.0);
  const double travel_s = std::abs(delta) / speed_;
  const Move m = Plan(from, delta, travel_s + kHomingApproachS);
  const double total_s = m.duration_s;
  if (m.stall_after_s >= 0.0) {
    // Stalls on the way, or on the approach to the switch (then it stands at 0).
    state_->clock_s = t + m.stall_after_s;
    physical_ = travel_s > 0.0 ? Wrap(from + delta * std::min(1.0, m.stall_after_s / travel_s)) : from;
    StateAngle() = physical_;
    lost_rad_ = ShorterWay(physical_, 0.0);  // the controller counted its steps to 0
    throw drivers::StallError(id() + ": stalled while homing");
  }
  state_->clock_s = t + total_s;
  physical_ = 0.0;
  StateAngle() = 0.0;
  target_ = 0.0;
  lost_rad_ = 0.0;
  // It reached the switch, but unconfirmed it does not count as homed.
  if (m.timeout_fault) throw drivers::TimeoutError(id() + ": the controller did not confirm the reference switch");
  homed_ = true;
}

void SimulatedRotaryStage::MoveTo(double angle_rad) {
  Update();
  ++state_->changes;
  if (!std::isfinite(angle_rad)) Fail("target angle is not a number");
  if (!homed_) Fail("not homed (position unknown); call Home() first");
  const double t = state_->clock_s;
  physical_ = PhysicalAt(t);  // a move under way is retargeted from here
  move_.reset();
  target_ = Wrap(angle_rad);
  const double delta = ShorterWay(physical_, target_);
  move_ = Plan(physical_, delta, std::abs(delta) / speed_);
}

void SimulatedRotaryStage::WaitUntilStopped(std::chrono::milliseconds timeout) {
  Update();
  if (!move_) return;
  const double t = state_->clock_s;
  const double timeout_s = std::max(0.0, Seconds(timeout));
  const Move m = *move_;
  const double stop_s = m.start_s + (m.stall_after_s >= 0.0 ? m.stall_after_s : m.duration_s);
  if (m.timeout_fault) {
    // The controller does not answer for the whole wait; the move goes on.
    move_->timeout_fault = false;
    state_->clock_s = t + timeout_s;
    Update();
    throw drivers::TimeoutError(id() + ": the controller did not answer within " + std::to_string(timeout.count()) +
                                " ms");
  }
  if (stop_s - t > timeout_s) {
    state_->clock_s = t + timeout_s;
    Update();
    throw drivers::TimeoutError(id() + ": still moving after " + std::to_string(timeout.count()) +
                                " ms (the move needs " + std::to_string(stop_s - t) + " s more)");
  }
  state_->clock_s = std::max(t, stop_s);
  Update();
  physical_ = PhysicalAt(state_->clock_s);
  move_.reset();
  if (m.stall_after_s >= 0.0) {
    homed_ = false;
    lost_rad_ = ShorterWay(physical_, target_);
    throw drivers::StallError(id() + ": stalled on the way to its target; home it again");
  }
}

bool SimulatedRotaryStage::IsMoving() const {
  const double t = state_->clock_s;
  return move_ && !StalledAt(t) && t < move_->start_s + move_->duration_s;
}

double SimulatedRotaryStage::Position() const {
  const double t = state_->clock_s;
  if (StalledAt(t)) return target_;  // its steps were all sent, some were lost
  return Wrap(PhysicalAt(t) + lost_rad_);
}

// ---------------------------------------------------------------- lamps

SimulatedLampBank::SimulatedLampBank(const formats::RigDescription& rig, std::shared_ptr<SimulatedRigState> state,
                                     const FaultPlan& faults, std::uint64_t seed)
    : state_(std::move(state)) {
  const int count = static_cast<int>(rig.lamps.elevations_rad.size());
  for (int i = 0; i < count; ++i) {
    failure_.emplace_back(faults, FaultKind::kLampFailure, LampDeviceId(i), seed);
  }
  dead_.assign(count, false);
  state_->lamps_on.assign(count, false);
}

void SimulatedLampBank::CheckIndex(int index) const {
  if (index < 0 || index >= lamp_count()) {
    throw drivers::DeviceError("lamps: no lamp " + std::to_string(index) + " (the bank has lamps 0 to " +
                               std::to_string(lamp_count() - 1) + ")");
  }
}

void SimulatedLampBank::SetLamp(int index, bool on) {
  CheckIndex(index);
  if (on && !state_->lamps_on[index]) {
    if (dead_[index] || failure_[index].Fires()) {
      dead_[index] = true;
      throw drivers::LampFailureError("lamps: lamp " + std::to_string(index) + " does not light (burnt out)");
    }
  }
  if (state_->lamps_on[index] != on) ++state_->changes;
  state_->lamps_on[index] = on;
}

bool SimulatedLampBank::IsOn(int index) const {
  CheckIndex(index);
  return state_->lamps_on[index];
}

bool SimulatedLampBank::IsDead(int index) const {
  CheckIndex(index);
  return dead_[index];
}

void SimulatedLampBank::ReplaceLamp(int index) {
  CheckIndex(index);
  dead_[index] = false;
}

// ---------------------------------------------------------------- laser

SimulatedLaserUnit::SimulatedLaserUnit(const formats::RigDescription& rig, std::shared_ptr<SimulatedRigState> state)
    : state_(std::move(state)), mount_count_(static_cast<int>(rig.laser.mount_elevations_rad.size())) {}

void SimulatedLaserUnit::SetEnabled(bool on) {
  if (state_->laser_on != on) ++state_->changes;
  state_->laser_on = on;
}

void SimulatedLaserUnit::SetTilt(double tilt_rad, std::chrono::milliseconds timeout) {
  if (!(std::abs(tilt_rad) <= kMaxTiltRad)) {
    throw drivers::DeviceError("laser unit: tilt " + std::to_string(tilt_rad) + " rad is outside " +
                               Range(-kMaxTiltRad, kMaxTiltRad, "rad"));
  }
  ++state_->changes;
  const double from = state_->laser_tilt_rad;
  const double needed_s = std::abs(tilt_rad - from) / kTiltSpeedRadPerS;
  const double timeout_s = std::max(0.0, Seconds(timeout));
  if (needed_s > timeout_s) {
    state_->clock_s += timeout_s;
    state_->laser_tilt_rad = from + std::copysign(kTiltSpeedRadPerS * timeout_s, tilt_rad - from);
    throw drivers::TimeoutError("laser unit: tilt not reached within " + std::to_string(timeout.count()) + " ms");
  }
  state_->clock_s += needed_s;
  state_->laser_tilt_rad = tilt_rad;
}

void SimulatedLaserUnit::SetMount(int mount) {
  if (mount < 0 || mount >= mount_count_) {
    throw drivers::DeviceError("laser unit: no mount " + std::to_string(mount) + " (the arc has mounts 0 to " +
                               std::to_string(mount_count_ - 1) + ")");
  }
  state_->laser_mount = mount;
  ++state_->changes;
}

}  // namespace mesocap::sim
