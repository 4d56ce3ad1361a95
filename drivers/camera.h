// The camera interface: every backend (the simulated rig, Aravis GigE Vision)
// implements it. Images come back linear, in sensor units normalized to
// [0, 1] of the full digital range, with the metadata needed to undo the
// exposure and gain in processing.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "core/image.h"

namespace mesocap::drivers {

struct CameraRegion {
  int x = 0;
  int y = 0;
  int width = 0;   // 0 = full sensor width
  int height = 0;  // 0 = full sensor height
};

// What a frame holds per pixel. A laser scan needs only the stripe's
// intensity: kMono reads one value a pixel (on a colour sensor the mean of
// its channels), a third of the values of an RGB frame to read out, move
// and process.
enum class PixelFormat {
  kNative,  // the sensor's channels (CameraInfo::channels)
  kMono,    // one channel
};

enum class TriggerMode {
  kFreeRun,   // the camera streams; Grab returns the next frame
  kSoftware,  // each frame waits for Trigger()
};

struct CameraSettings {
  double exposure_us = 10000.0;
  double gain_db = 0.0;
  CameraRegion region;
  PixelFormat pixel_format = PixelFormat::kNative;
  TriggerMode trigger = TriggerMode::kSoftware;
};

struct CameraInfo {
  std::string id;
  std::string model;
  int sensor_width = 0;
  int sensor_height = 0;
  int bit_depth = 8;  // of the digitized values
  int channels = 1;   // 1 = mono, 3 = RGB
};

struct Frame {
  core::Image image;           // values in [0, 1] of the digital range
  std::uint64_t sequence = 0;  // per camera, increasing; a gap means a dropped frame
  double timestamp_s = 0.0;    // camera clock
  CameraSettings settings;     // in force when the frame was exposed
  int bit_depth = 8;
  std::uint64_t saturated_pixels = 0;  // values at the top code
};

class Camera {
 public:
  virtual ~Camera() = default;

  virtual CameraInfo info() const = 0;
  virtual CameraSettings settings() const = 0;
  // Asks the device whether it still answers (info() and settings() are
  // what it said when opened, and ask nothing); false once it is gone and
  // must be reopened. Never counts as an operation of the capture.
  virtual bool IsConnected() = 0;
  // Setters throw DeviceError for a value the device cannot take (the
  // message says the valid range) and DisconnectedError when gone.
  virtual void SetExposure(double exposure_us) = 0;
  virtual void SetGain(double gain_db) = 0;
  virtual void SetRegion(const CameraRegion& region) = 0;
  virtual void SetPixelFormat(PixelFormat format) = 0;
  virtual void SetTrigger(TriggerMode mode) = 0;

  // Gets ready for triggers after a setting changed (GenICam's
  // AcquisitionStart; Trigger does it too when needed). A step starts every
  // camera it uses before it triggers any: a GigE Vision stream started while
  // another camera of the rig sends can take that camera's frame for its own.
  virtual void StartAcquisition() {}
  // Starts exposing one frame (kSoftware mode). A frame that arrived before
  // it answers an earlier trigger and is discarded, not handed out.
  virtual void Trigger() = 0;
  // The next frame. Throws TimeoutError when none arrives within `timeout`,
  // DisconnectedError when the camera is gone.
  virtual Frame Grab(std::chrono::milliseconds timeout) = 0;
};

}  // namespace mesocap::drivers
