// A GenICam camera (GigE Vision or USB3 Vision) through Aravis 0.8, behind
// the camera interface. Frames stream into a pool of buffers allocated when
// the stream starts (none per frame); GigE Vision frame ids are unwrapped
// into the interface's sequence, and a gap counts as dropped frames.
//
// Failures: a frame that does not come in time is a TimeoutError when the
// camera still answers on its control channel, and a DisconnectedError when
// it does not (or Aravis reported the control lost: no heartbeat answer).
// Reopen() opens the same device again, by the same id or address, and
// restores the settings.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>

#include "core/error.h"
#include "drivers/aravis/pixel_format.h"
#include "drivers/aravis/stream_ports.h"
#include "drivers/camera.h"

struct _GError;     // GLib's GError and Aravis' camera and buffer, without
struct _ArvCamera;  // their headers in this one
struct _ArvBuffer;

namespace mesocap::drivers::aravis {

struct AravisCameraOptions {
  std::string id;      // the rig's camera id: names the frames and the errors
  std::string device;  // Aravis device id, serial number or IPv4 address
  // Frames the stream can hold while Grab is not called: 16 keep 8 cameras
  // at 7.5 Hz from dropping on a loaded 2-core host (docs/BENCHMARKS.md).
  int buffer_count = 16;
  // GigE Vision packet size in bytes; 0 negotiates the largest one that
  // reaches this host unfragmented.
  int packet_size = 0;
  bool packet_resend = true;   // ask the camera to resend lost packets
  double frame_rate_hz = 0.0;  // free run; 0 keeps the camera's
  // GenICam pixel format names; "" picks: for kNative the RGB format with
  // the most bits, else a Bayer one, else mono; for kMono the mono format
  // with the most bits.
  std::string native_pixel_format;
  std::string mono_pixel_format;
  // The ports the rig's other cameras' streams hold (drivers/aravis/
  // stream_ports.h); null for a camera on its own.
  std::shared_ptr<StreamPorts> stream_ports;

  // "" when usable, else what is wrong, naming the field.
  core::CheckResult Check() const;
};

class AravisCamera : public Camera {
 public:
  // Opens the camera. Throws Error for bad options, DisconnectedError when
  // the device cannot be reached, DeviceError when it lacks what mesocap
  // needs (a supported pixel format, exposure control).
  explicit AravisCamera(AravisCameraOptions options);
  ~AravisCamera() override;
  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  CameraInfo info() const override { return info_; }
  CameraSettings settings() const override { return settings_; }
  // Reads the exposure time over the control channel.
  bool IsConnected() override;
  void SetExposure(double exposure_us) override;
  void SetGain(double gain_db) override;
  void SetRegion(const CameraRegion& region) override;
  void SetPixelFormat(PixelFormat format) override;
  void SetTrigger(TriggerMode mode) override;
  // In kSoftware mode, the stream a setting stopped.
  void StartAcquisition() override;
  void Trigger() override;
  Frame Grab(std::chrono::milliseconds timeout) override;

  // Closes the device and opens it again (after a DisconnectedError).
  void Reopen();

  // Frames the stream lost: frame-id gaps and incomplete buffers.
  std::uint64_t dropped_frames() const { return dropped_frames_; }
  // The GigE Vision packet size in use (0 for a USB3 Vision camera).
  int packet_size() const { return packet_size_; }
  const PixelFormatTraits& pixel_format_in_use() const;

 private:
  struct Device;  // the Aravis objects, so that arv.h stays out of this header

  void Open();
  void Close();
  // The open camera; DisconnectedError when a reopen failed and left none.
  ::_ArvCamera* Connected() const;
  void StartStream();
  // The stream, on a port no other camera of the rig holds (StreamPorts).
  void CreateStream();
  void StopStream();
  void ApplySettings();
  // Sets a float feature after checking it against the device's bounds.
  void SetBounded(const std::string& what, const std::string& unit, double value,
                  void (*bounds)(::_ArvCamera*, double*, double*, ::_GError**),
                  void (*set)(::_ArvCamera*, double, ::_GError**));
  // Throws the typed error for a failed Aravis call (takes `error`).
  [[noreturn]] void Fail(const std::string& what, ::_GError* error) const;
  void Check(const std::string& what, ::_GError* error) const;
  // Disconnects and frees the ArvCamera, leaving device_ without one.
  void ReleaseCamera();
  // Counts the frames missing before frame `id` as dropped; returns how many.
  std::uint64_t CountFrameId(std::uint64_t id);
  // A frame arrived after `missing_before` lost ones: that many triggers
  // and one more are answered.
  void SettleOwedFrames(std::uint64_t missing_before);
  // The frame in `buffer`, which goes back to the stream.
  Frame Decoded(::_ArvBuffer* buffer);

  AravisCameraOptions options_;
  std::unique_ptr<Device> device_;
  CameraInfo info_;
  CameraSettings settings_;
  PixelFormatTraits native_format_;
  PixelFormatTraits mono_format_;
  int packet_size_ = 0;
  std::uint64_t dropped_frames_ = 0;
  std::uint64_t next_sequence_ = 0;
  std::uint64_t last_frame_id_ = 0;
  bool have_frame_id_ = false;
  // Software triggers whose frame has not arrived: more than one while a
  // Grab that timed out is retried (Grab).
  std::uint64_t owed_frames_ = 0;
  bool opened_before_ = false;
};

}  // namespace mesocap::drivers::aravis
