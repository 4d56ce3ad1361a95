#include "drivers/aravis/aravis_camera.h"

#include <arv.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <utility>
#include <vector>

#include "core/error.h"
#include "drivers/aravis/camera_discovery.h"
#include "drivers/device_error.h"

namespace mesocap::drivers::aravis {
namespace {

// GigE Vision frame ids are 16 bits and skip 0 (GigE Vision 1.2, Sec. 20);
// Aravis reports the extended 64-bit ids of GigE Vision 2 as they are.
constexpr std::uint64_t kLargestShortFrameId = 65535;

// How near the top a 16-bit id must be, and how near the bottom the next,
// to read as a wrap rather than a late frame or a restarted count.
constexpr std::uint64_t kWrapWindow = 1024;

// How long the stream waits for a frame's missing packets before it gives
// the frame up. Aravis' default (100 ms) drops frames whose stream thread
// was merely scheduled late on a loaded host.
constexpr guint kFrameRetentionUs = 1000000;

// The stream socket's receive buffer, in payloads of a frame, and its
// least size, for a process that cannot open Aravis' packet socket (no
// CAP_NET_RAW) and receives on the UDP socket. The kernel charges a
// datagram its buffers too (a 1.4 KB GVSP packet costs about twice that on
// loopback), so a buffer of one payload, Aravis' "auto", overflows before a
// late stream thread reads a small frame's last packets. The kernel caps it
// at net.core.rmem_max.
constexpr guint kSocketBufferPayloads = 4;
constexpr guint kLeastSocketBufferBytes = 1u << 20;

// Streams made before one gets a port no other camera of the rig holds
// (stream_ports.h: a collision is about 1 in 7000).
constexpr int kStreamAttempts = 8;

std::uint64_t FrameIdGap(std::uint64_t last, std::uint64_t id) {
  if (id > last) return id - last - 1;
  if (last <= kLargestShortFrameId && last > kLargestShortFrameId - kWrapWindow && id >= 1 && id < kWrapWindow) {
    return (kLargestShortFrameId - last) + (id - 1);
  }
  return 0;  // a late or repeated frame, or the camera restarted its count
}

// Errors that say the control channel no longer answers (after Aravis'
// own retries), as opposed to a request the camera refused.
bool IsUnreachable(const GError* error) {
  return error && error->domain == ARV_DEVICE_ERROR &&
         (error->code == ARV_DEVICE_ERROR_TIMEOUT || error->code == ARV_DEVICE_ERROR_NOT_CONNECTED ||
          error->code == ARV_DEVICE_ERROR_NOT_FOUND || error->code == ARV_DEVICE_ERROR_TRANSFER_ERROR);
}

std::string Formats(const std::vector<std::string>& names) {
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  return list.empty() ? "none" : list;
}

}  // namespace

struct AravisCamera::Device {
  ArvCamera* camera = nullptr;
  ArvStream* stream = nullptr;
  gulong control_lost_handler = 0;
  std::atomic<bool> control_lost{false};
  bool acquiring = false;
  std::uint16_t stream_port = 0;  // held in the rig's StreamPorts; 0: none
  // The stream's buffers point into these; they outlive the stream.
  std::vector<std::vector<std::byte>> pool;

  static void OnControlLost(ArvDevice*, gpointer self) { static_cast<Device*>(self)->control_lost = true; }
};

core::CheckResult AravisCameraOptions::Check() const {
  if (id.empty()) return "id: expected the rig's camera id";
  if (device.empty()) return "device: expected an Aravis device id, serial number or address";
  if (buffer_count < 2 || buffer_count > 256) return "buffer_count: expected 2 to 256 buffers";
  if (packet_size != 0 && (packet_size < 576 || packet_size > 65535)) {
    return "packet_size: expected 0 (negotiate) or 576 to 65535 bytes";
  }
  if (!(frame_rate_hz >= 0.0 && frame_rate_hz <= 1e5)) return "frame_rate_hz: expected 0 to 100000";
  for (const auto* name : {&native_pixel_format, &mono_pixel_format}) {
    if (!name->empty() && !FindPixelFormat(*name)) {
      std::vector<std::string> known;
      for (const auto& f : SupportedPixelFormats()) known.push_back(f.name);
      return (name == &native_pixel_format ? "native_pixel_format" : "mono_pixel_format") +
             std::string(": unknown pixel format ") + core::Quoted(*name) + " (known: " + Formats(known) + ")";
    }
  }
  return "";
}

AravisCamera::AravisCamera(AravisCameraOptions options) : options_(std::move(options)) {
  core::ThrowIfInvalid(options_.Check(), "camera " + options_.id);
  Open();
}

AravisCamera::~AravisCamera() { Close(); }

const PixelFormatTraits& AravisCamera::pixel_format_in_use() const {
  return settings_.pixel_format == PixelFormat::kMono ? mono_format_ : native_format_;
}

void AravisCamera::Check(const std::string& what, GError* error) const {
  if (error != nullptr) Fail(what, error);
}

void AravisCamera::Fail(const std::string& what, GError* error) const {
  const std::string message = error ? error->message : "failed";
  const bool unreachable = IsUnreachable(error);
  if (error) g_error_free(error);
  const std::string camera = "camera " + options_.id + " (" + options_.device + "): ";
  // A control channel that no longer answers after Aravis' retries is a
  // camera that is gone, not a slow one.
  if (unreachable || (device_ && device_->control_lost)) {
    throw DisconnectedError(camera + "disconnected (no answer on the control channel): " + what + ": " + message);
  }
  throw DeviceError(camera + what + ": " + message);
}

void AravisCamera::Open() {
  device_ = std::make_unique<Device>();
  std::string name;
  try {
    name = ResolveCamera(options_.device);
  } catch (const DeviceError& e) {
    throw DisconnectedError("camera " + options_.id + ": " + e.what());
  }
  GError* error = nullptr;
  device_->camera = arv_camera_new(name.c_str(), &error);
  if (device_->camera == nullptr) {
    const std::string message = error ? error->message : "not found";
    if (error) g_error_free(error);
    throw DisconnectedError("camera " + options_.id + ": cannot open " + core::Quoted(options_.device) + ": " +
                            message);
  }
  device_->control_lost_handler = g_signal_connect(arv_camera_get_device(device_->camera), "control-lost",
                                                   G_CALLBACK(Device::OnControlLost), device_.get());
  // A camera refused or failing on the way (in the constructor, where no
  // destructor follows) is let go at once, with its control socket.
  try {
    ArvCamera* cam = device_->camera;
    // GigE Vision gives one application control; without it every setting
    // would fail as if the camera were gone.
    if (arv_camera_is_gv_device(cam) && !arv_gv_device_is_controller(ARV_GV_DEVICE(arv_camera_get_device(cam)))) {
      throw DeviceError("camera " + options_.id + " (" + options_.device +
                        "): another program controls it (a GigE Vision camera takes one controller); close it first");
    }
    info_.id = options_.id;
    const char* model = arv_camera_get_model_name(cam, &error);
    Check("reading DeviceModelName", error);
    const char* vendor = arv_camera_get_vendor_name(cam, &error);
    Check("reading DeviceVendorName", error);
    info_.model = std::string(vendor ? vendor : "") + " " + (model ? model : "");
    arv_camera_get_sensor_size(cam, &info_.sensor_width, &info_.sensor_height, &error);
    Check("reading the sensor size", error);

    guint n = 0;
    const char** names = arv_camera_dup_available_pixel_formats_as_strings(cam, &n, &error);
    Check("reading the pixel formats", error);
    std::vector<std::string> offered;
    for (guint i = 0; i < n; ++i) offered.emplace_back(names[i]);
    g_free(names);
    // Most bits first; for colour an RGB format before a Bayer mosaic. A
    // mono-only camera delivers mono frames as its native ones.
    auto pick = [&](const std::string& wanted, bool mono) -> std::optional<PixelFormatTraits> {
      if (!wanted.empty()) {
        if (std::find(offered.begin(), offered.end(), wanted) == offered.end()) {
          throw DeviceError("camera " + options_.id + ": pixel format " + core::Quoted(wanted) +
                            " is not offered (offered: " + Formats(offered) + ")");
        }
        return FindPixelFormat(wanted);
      }
      std::optional<PixelFormatTraits> best;
      auto rank = [](const PixelFormatTraits& f) { return f.bit_depth * 2 + (f.bayer == BayerPattern::kNone ? 1 : 0); };
      for (const auto& o : offered) {
        const auto f = FindPixelFormat(o);
        if (!f || (f->channels == 1) != mono) continue;
        if (!best || rank(*f) > rank(*best)) best = f;
      }
      return best;
    };
    const auto mono = pick(options_.mono_pixel_format, true);
    const auto native = pick(options_.native_pixel_format, false);
    if (!mono && !native) {
      throw DeviceError("camera " + options_.id + ": none of its pixel formats (" + Formats(offered) +
                        ") is one mesocap reads");
    }
    native_format_ = native ? *native : *mono;
    mono_format_ = mono ? *mono : *native;
    info_.channels = native_format_.channels;
    info_.bit_depth = native_format_.bit_depth;

    if (arv_camera_is_gv_device(cam)) {
      if (options_.packet_size > 0) {
        arv_camera_gv_set_packet_size(cam, options_.packet_size, &error);
        Check("setting the packet size", error);
        packet_size_ = options_.packet_size;
      } else {
        packet_size_ = static_cast<int>(arv_camera_gv_auto_packet_size(cam, &error));
        Check("negotiating the packet size", error);
      }
    }
    if (options_.frame_rate_hz > 0.0) {
      arv_camera_set_frame_rate(cam, options_.frame_rate_hz, &error);
      Check("setting AcquisitionFrameRate", error);
    }
    // A reopened camera gets the settings it had; a new one keeps the device's.
    if (!opened_before_) {
      opened_before_ = true;
      settings_.exposure_us = arv_camera_get_exposure_time(cam, &error);
      Check("reading the exposure time", error);
      if (arv_camera_is_gain_available(cam, nullptr)) {
        settings_.gain_db = arv_camera_get_gain(cam, &error);
        Check("reading the gain", error);
      }
    }
    ApplySettings();
  } catch (...) {
    ReleaseCamera();
    throw;
  }
}

void AravisCamera::ReleaseCamera() {
  if (!device_ || !device_->camera) return;
  if (device_->control_lost_handler != 0) {
    g_signal_handler_disconnect(arv_camera_get_device(device_->camera), device_->control_lost_handler);
    device_->control_lost_handler = 0;
  }
  g_object_unref(device_->camera);
  device_->camera = nullptr;
}

void AravisCamera::ApplySettings() {
  // Through the setters, so that a reopened camera gets every setting back.
  const CameraSettings wanted = settings_;
  SetPixelFormat(wanted.pixel_format);
  SetRegion(wanted.region);
  SetExposure(wanted.exposure_us);
  SetGain(wanted.gain_db);
  SetTrigger(wanted.trigger);
}

void AravisCamera::Close() {
  if (!device_) return;
  StopStream();
  ReleaseCamera();
  device_.reset();
}

ArvCamera* AravisCamera::Connected() const {
  if (!device_ || !device_->camera) {
    throw DisconnectedError("camera " + options_.id + " (" + options_.device +
                            "): disconnected (it went away and could not be opened again)");
  }
  return device_->camera;
}

bool AravisCamera::IsConnected() {
  if (!device_ || !device_->camera || device_->control_lost) return false;
  GError* error = nullptr;
  arv_camera_get_exposure_time(device_->camera, &error);
  const bool unreachable = IsUnreachable(error);
  if (error) g_error_free(error);
  return !unreachable && !device_->control_lost;
}

void AravisCamera::Reopen() {
  Close();
  Open();
}

void AravisCamera::StartStream() {
  if (device_->acquiring) return;
  ArvCamera* cam = Connected();
  GError* error = nullptr;
  const guint payload = arv_camera_get_payload(cam, &error);
  Check("reading PayloadSize", error);
  if (device_->stream == nullptr) {
    CreateStream();
    if (ARV_IS_GV_STREAM(device_->stream)) {
      // A receive buffer that holds a whole frame, so that a stream thread
      // scheduled late loses no packet.
      const guint buffer_bytes = std::max(kLeastSocketBufferBytes, kSocketBufferPayloads * payload);
      g_object_set(device_->stream, "packet-resend",
                   options_.packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS : ARV_GV_STREAM_PACKET_RESEND_NEVER,
                   "socket-buffer", ARV_GV_STREAM_SOCKET_BUFFER_FIXED, "socket-buffer-size",
                   static_cast<gint>(std::min<guint>(buffer_bytes, G_MAXINT)), "frame-retention", kFrameRetentionUs,
                   nullptr);
    }
    device_->pool.assign(options_.buffer_count, std::vector<std::byte>(payload));
    for (auto& memory : device_->pool) {
      arv_stream_push_buffer(device_->stream, arv_buffer_new(memory.size(), memory.data()));
    }
  }
  arv_camera_set_acquisition_mode(cam, ARV_ACQUISITION_MODE_CONTINUOUS, &error);
  Check("setting AcquisitionMode", error);
  arv_camera_start_acquisition(cam, &error);
  Check("starting the acquisition", error);
  device_->acquiring = true;
  have_frame_id_ = false;
  owed_frames_ = 0;
}

void AravisCamera::CreateStream() {
  ArvCamera* cam = Connected();
  for (int attempt = 1;; ++attempt) {
    GError* error = nullptr;
    device_->stream = arv_camera_create_stream(cam, nullptr, nullptr, &error);
    if (device_->stream == nullptr) Fail("creating the stream", error);
    if (!options_.stream_ports || !ARV_IS_GV_STREAM(device_->stream)) return;
    // A port another camera of the rig holds would share its packets.
    const std::uint16_t port = arv_gv_stream_get_port(ARV_GV_STREAM(device_->stream));
    if (options_.stream_ports->Claim(port)) {
      device_->stream_port = port;
      return;
    }
    g_object_unref(device_->stream);
    device_->stream = nullptr;
    if (attempt == kStreamAttempts) {
      throw DeviceError("camera " + options_.id + ": " + std::to_string(kStreamAttempts) +
                        " streams in a row got a port another camera's stream holds");
    }
  }
}

void AravisCamera::StopStream() {
  if (!device_) return;
  if (device_->acquiring && device_->camera && !device_->control_lost) {
    GError* error = nullptr;
    arv_camera_stop_acquisition(device_->camera, &error);
    if (error) g_error_free(error);  // stopping a camera that is gone: nothing to do
  }
  device_->acquiring = false;
  // The stream's buffers point into the pool: a payload change needs both anew.
  if (device_->stream) {
    g_object_unref(device_->stream);
    device_->stream = nullptr;
  }
  if (device_->stream_port != 0) options_.stream_ports->Release(device_->stream_port);
  device_->stream_port = 0;
  device_->pool.clear();
}

void AravisCamera::SetBounded(const std::string& what, const std::string& unit, double value,
                              void (*bounds)(ArvCamera*, double*, double*, GError**),
                              void (*set)(ArvCamera*, double, GError**)) {
  GError* error = nullptr;
  double lo = 0.0, hi = 0.0;
  bounds(Connected(), &lo, &hi, &error);
  Check("reading the " + what + " bounds", error);
  if (!(value >= lo && value <= hi)) {
    throw DeviceError("camera " + options_.id + ": " + what + " " + std::to_string(value) + " " + unit +
                      " is outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "] " + unit);
  }
  set(Connected(), value, &error);
  Check("setting the " + what, error);
}

void AravisCamera::SetExposure(double exposure_us) {
  SetBounded("exposure", "us", exposure_us, arv_camera_get_exposure_time_bounds, arv_camera_set_exposure_time);
  settings_.exposure_us = exposure_us;
}

void AravisCamera::SetGain(double gain_db) {
  if (!arv_camera_is_gain_available(Connected(), nullptr)) {
    if (gain_db == 0.0) return;
    throw DeviceError("camera " + options_.id + ": has no gain control");
  }
  SetBounded("gain", "dB", gain_db, arv_camera_get_gain_bounds, arv_camera_set_gain);
  settings_.gain_db = gain_db;
}

void AravisCamera::SetRegion(const CameraRegion& region) {
  const int width = region.width == 0 ? info_.sensor_width : region.width;
  const int height = region.height == 0 ? info_.sensor_height : region.height;
  if (region.x < 0 || region.y < 0 || width <= 0 || height <= 0 || region.x + width > info_.sensor_width ||
      region.y + height > info_.sensor_height) {
    throw DeviceError("camera " + options_.id + ": region " + std::to_string(width) + " x " + std::to_string(height) +
                      " at (" + std::to_string(region.x) + ", " + std::to_string(region.y) + ") is not inside the " +
                      std::to_string(info_.sensor_width) + " x " + std::to_string(info_.sensor_height) + " sensor");
  }
  StopStream();  // the payload changes
  GError* error = nullptr;
  // Shrink before moving, so that no intermediate region leaves the sensor.
  arv_camera_set_region(Connected(), 0, 0, width, height, &error);
  Check("setting the region size", error);
  arv_camera_set_region(Connected(), region.x, region.y, width, height, &error);
  Check("setting the region", error);
  settings_.region = region;
}

void AravisCamera::SetPixelFormat(PixelFormat format) {
  StopStream();
  const PixelFormatTraits& traits = format == PixelFormat::kMono ? mono_format_ : native_format_;
  GError* error = nullptr;
  arv_camera_set_pixel_format(Connected(), traits.code, &error);
  Check("setting PixelFormat " + traits.name, error);
  settings_.pixel_format = format;
}

void AravisCamera::SetTrigger(TriggerMode mode) {
  StopStream();  // frames of the old mode must not answer the new one's triggers
  GError* error = nullptr;
  if (mode == TriggerMode::kSoftware) {
    arv_camera_set_trigger(Connected(), "Software", &error);
    Check("setting the software trigger", error);
  } else {
    arv_camera_clear_triggers(Connected(), &error);
    Check("clearing the triggers", error);
  }
  settings_.trigger = mode;
}

void AravisCamera::StartAcquisition() {
  // Aravis' packet socket takes every packet on the interface until its
  // filter is attached: started after another camera's trigger, this
  // stream completed that camera's frame as its own.
  if (settings_.trigger == TriggerMode::kSoftware) StartStream();
}

void AravisCamera::Trigger() {
  if (settings_.trigger != TriggerMode::kSoftware) return;
  StartStream();
  // A frame already waiting answers an earlier trigger (one that timed out
  // and was retried): left there, the next Grab would hand it out as this
  // trigger's frame, taken before the rig moved on. It is not lost, so it
  // moves the frame id on without counting as dropped.
  while (ArvBuffer* stale = arv_stream_try_pop_buffer(device_->stream)) {
    SettleOwedFrames(CountFrameId(arv_buffer_get_frame_id(stale)));
    arv_stream_push_buffer(device_->stream, stale);
  }
  GError* error = nullptr;
  arv_camera_software_trigger(Connected(), &error);
  Check("TriggerSoftware", error);
  ++owed_frames_;
}

std::uint64_t AravisCamera::CountFrameId(std::uint64_t id) {
  if (id == 0) return 0;  // no id: GigE Vision never sends 0
  const std::uint64_t gap = have_frame_id_ ? FrameIdGap(last_frame_id_, id) : 0;
  dropped_frames_ += gap;
  next_sequence_ += gap;
  last_frame_id_ = id;
  have_frame_id_ = true;
  return gap;
}

void AravisCamera::SettleOwedFrames(std::uint64_t missing_before) {
  const std::uint64_t settled = missing_before + 1;
  owed_frames_ = settled >= owed_frames_ ? 0 : owed_frames_ - settled;
}

Frame AravisCamera::Grab(std::chrono::milliseconds timeout) {
  StartStream();
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  // A frame that answers an earlier trigger of this one's (it timed out and
  // was retried, the rig unchanged): the retry's own frame comes after it
  // and is the answer, so that which frame answers does not depend on when
  // the first was given up; if none comes (a busy camera may ignore a
  // trigger), this one is.
  ArvBuffer* earlier = nullptr;
  for (;;) {
    const auto left =
        std::chrono::duration_cast<std::chrono::microseconds>(deadline - std::chrono::steady_clock::now());
    ArvBuffer* buffer =
        left.count() > 0 ? arv_stream_timeout_pop_buffer(device_->stream, static_cast<guint64>(left.count())) : nullptr;
    // The retry's frame stays owed: should it come late, the next Grab sets
    // it aside too.
    if (buffer == nullptr && earlier != nullptr) return Decoded(std::exchange(earlier, nullptr));
    if (buffer == nullptr) {
      // Tell a slow frame from a camera that is gone: ask the camera.
      GError* error = nullptr;
      if (!device_->control_lost) arv_camera_get_integer(Connected(), "Width", &error);
      if (device_->control_lost || error != nullptr) Fail("no frame", error);
      throw TimeoutError("camera " + options_.id + ": no frame within " + std::to_string(timeout.count()) + " ms");
    }
    // Every GVSP packet carries its frame's id, so an incomplete frame has
    // one too: it and the frames missing before it are dropped.
    SettleOwedFrames(CountFrameId(arv_buffer_get_frame_id(buffer)));
    if (arv_buffer_get_status(buffer) != ARV_BUFFER_STATUS_SUCCESS) {
      ++dropped_frames_;
      ++next_sequence_;
      arv_stream_push_buffer(device_->stream, buffer);
      continue;
    }
    // Set aside, not dropped: its id moved the count on.
    if (earlier != nullptr) arv_stream_push_buffer(device_->stream, earlier);
    earlier = nullptr;
    if (owed_frames_ > 0) {
      earlier = buffer;
      continue;
    }
    return Decoded(buffer);
  }
}

Frame AravisCamera::Decoded(ArvBuffer* buffer) {
  Frame frame;
  frame.sequence = next_sequence_++;
  frame.timestamp_s = static_cast<double>(arv_buffer_get_timestamp(buffer)) * 1e-9;
  frame.settings = settings_;
  const auto format = FindPixelFormat(static_cast<std::uint32_t>(arv_buffer_get_image_pixel_format(buffer)));
  size_t size = 0;
  const void* data = arv_buffer_get_image_data(buffer, &size);
  const int width = arv_buffer_get_image_width(buffer);
  const int height = arv_buffer_get_image_height(buffer);
  try {
    if (!format) throw DeviceError("a frame arrived in a pixel format mesocap does not read");
    frame.bit_depth = format->bit_depth;
    frame.saturated_pixels =
        DecodePixels({static_cast<const std::byte*>(data), size}, width, height, *format, frame.image);
  } catch (const core::Error& e) {
    arv_stream_push_buffer(device_->stream, buffer);
    throw DeviceError("camera " + options_.id + ": " + e.what());
  }
  arv_stream_push_buffer(device_->stream, buffer);
  return frame;
}

}  // namespace mesocap::drivers::aravis
