// The Aravis backend against real GigE Vision devices on loopback: cameras
// served by Aravis' fake GigE Vision device in this process (sim/
// served_cameras.h), in a network namespace of the test's own
// (scripts/in-network-namespace.sh).
#include "drivers/aravis/aravis_camera.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include "drivers/aravis/camera_discovery.h"
#include "drivers/device_error.h"
#include "sim/served_cameras.h"

namespace mesocap::drivers::aravis {
namespace {

constexpr int kWidth = 64;
constexpr int kHeight = 48;
constexpr int kBits = 12;
constexpr double kMaxCode = (1 << kBits) - 1;

// The code a PatternCamera gives pixel (x, y), channel c of frame n (over
// the whole sensor; a region shows its part). Pixel (0, 0) channel 0 holds n.
int PatternCode(int n, int x, int y, int c) {
  if (x == 0 && y == 0 && c == 0) return n % 4096;
  return (x * 7 + y * 13 + c * 101 + n * 17) % 4096;
}

// A camera whose frames are a known pattern: what arrives over the network
// can be checked pixel by pixel.
class PatternCamera : public Camera {
 public:
  CameraInfo info() const override { return {"pattern", "test pattern", kWidth, kHeight, kBits, 3}; }
  CameraSettings settings() const override { return settings_; }
  void SetExposure(double us) override { settings_.exposure_us = us; }
  void SetGain(double db) override { settings_.gain_db = db; }
  void SetRegion(const CameraRegion& r) override { settings_.region = r; }
  void SetPixelFormat(PixelFormat f) override { settings_.pixel_format = f; }
  void SetTrigger(TriggerMode m) override { settings_.trigger = m; }
  void Trigger() override {}
  Frame Grab(std::chrono::milliseconds) override {
    const auto& r = settings_.region;
    const int w = r.width ? r.width : kWidth, h = r.height ? r.height : kHeight;
    const int channels = settings_.pixel_format == PixelFormat::kMono ? 1 : 3;
    Frame f;
    f.image = core::Image(w, h, channels);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < channels; ++c)
          f.image.pixel(x, y)[c] = static_cast<float>(PatternCode(frames_, r.x + x, r.y + y, c) / kMaxCode);
    f.sequence = frames_++;
    f.settings = settings_;
    last_settings = settings_;
    return f;
  }
  CameraSettings last_settings;

 private:
  CameraSettings settings_;
  int frames_ = 0;
};

std::unique_ptr<sim::ServedCameras> Serve(PatternCamera** camera = nullptr, const std::string& address = "127.0.0.1") {
  auto pattern = std::make_unique<PatternCamera>();
  if (camera) *camera = pattern.get();
  std::vector<std::unique_ptr<Camera>> cameras;
  cameras.push_back(std::move(pattern));
  return std::make_unique<sim::ServedCameras>(std::move(cameras),
                                              std::vector<sim::ServedCameraAddress>{{address, "PATTERN01"}});
}

AravisCameraOptions Options(const std::string& device = "127.0.0.1") {
  AravisCameraOptions o;
  o.id = "cam0";
  o.device = device;
  return o;
}

TEST(AravisCamera, DiscoveryFindsTheServedCameraAndOpensItBySerial) {
  auto served = Serve();
  const auto cameras = DiscoverCameras();
  bool found = false;
  for (const auto& c : cameras) found |= c.serial == "PATTERN01" && c.address == "127.0.0.1";
  EXPECT_TRUE(found);
  AravisCamera camera(Options("PATTERN01"));
  EXPECT_EQ(camera.info().sensor_width, kWidth);
  EXPECT_EQ(camera.info().bit_depth, 12);
  EXPECT_EQ(camera.info().channels, 3);
}

TEST(AravisCamera, SoftwareTriggeredFramesArriveExact) {
  PatternCamera* pattern = nullptr;
  auto served = Serve(&pattern);
  AravisCamera camera(Options());
  camera.SetTrigger(TriggerMode::kSoftware);
  for (int i = 0; i < 3; ++i) {
    camera.Trigger();
    const Frame f = camera.Grab(std::chrono::milliseconds(2000));
    ASSERT_EQ(f.image.width(), kWidth);
    ASSERT_EQ(f.image.channels(), 3);
    const int n = static_cast<int>(std::lround(f.image.pixel(0, 0)[0] * kMaxCode));
    int wrong = 0;
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x)
        for (int c = 0; c < 3; ++c)
          wrong += f.image.pixel(x, y)[c] != static_cast<float>(PatternCode(n, x, y, c) / kMaxCode);
    EXPECT_EQ(wrong, 0);
    std::printf("n %d, px %f %f %f served %lu failed %lu\n", n, f.image.pixel(1,0)[0]*kMaxCode, f.image.pixel(1,0)[1]*kMaxCode, f.image.pixel(5,5)[2]*kMaxCode,
       (unsigned long) served->frames_served(0), (unsigned long) served->frames_failed(0));
  }
}

TEST(AravisCamera, KilledServerGivesDisconnectedThenReopens) {
  auto served = Serve();
  AravisCamera camera(Options());
  camera.SetTrigger(TriggerMode::kSoftware);
  camera.Trigger();
  camera.Grab(std::chrono::milliseconds(2000));
  served.reset();
  const auto start = std::chrono::steady_clock::now();
  EXPECT_THROW(
      {
        camera.Trigger();
        camera.Grab(std::chrono::milliseconds(1000));
      },
      DisconnectedError);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("disconnect detected after %.2f s\n", s);
  EXPECT_THROW(camera.Reopen(), DisconnectedError);
  served = Serve();
  camera.Reopen();
  camera.Trigger();
  EXPECT_NO_THROW(camera.Grab(std::chrono::milliseconds(2000)));
}

}  // namespace
}  // namespace mesocap::drivers::aravis
