// Frames through the Aravis backend from cameras served as GigE Vision
// devices on loopback (sim/served_cameras.h), at the paper rig's 1024 x 768:
// frames per second and MB/s received against the rate the devices send,
// dropped frames, and CPU per frame. Server and client share this process
// and its cores, so the CPU figure is both ends of the link together.
// Run it in a network namespace with a loopback address per camera:
//   scripts/in-network-namespace.sh build/release/bench/mesocap_gige_vision_bench
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include "drivers/aravis/aravis_camera.h"
#include "sim/served_cameras.h"

namespace mesocap {
namespace {

constexpr int kWidth = 1024;
constexpr int kHeight = 768;

// A camera whose frames are one fixed 12-bit image: the bench measures the
// link, not a renderer.
class StillCamera : public drivers::Camera {
 public:
  explicit StillCamera(std::string id) : id_(std::move(id)) {
    for (int channels : {1, 3}) {
      core::Image& image = channels == 1 ? mono_ : colour_;
      image = core::Image(kWidth, kHeight, channels);
      for (std::size_t i = 0; i < image.size(); ++i) image.data()[i] = static_cast<float>((i * 7 % 4096) / 4095.0);
    }
  }
  drivers::CameraInfo info() const override { return {id_, "still", kWidth, kHeight, 12, 3}; }
  drivers::CameraSettings settings() const override { return settings_; }
  bool IsConnected() override { return true; }
  void SetExposure(double us) override { settings_.exposure_us = us; }
  void SetGain(double db) override { settings_.gain_db = db; }
  void SetRegion(const drivers::CameraRegion& r) override { settings_.region = r; }
  void SetPixelFormat(drivers::PixelFormat f) override { settings_.pixel_format = f; }
  void SetTrigger(drivers::TriggerMode m) override { settings_.trigger = m; }
  void Trigger() override {}
  drivers::Frame Grab(std::chrono::milliseconds) override {
    drivers::Frame f;
    f.image = settings_.pixel_format == drivers::PixelFormat::kMono ? mono_ : colour_;
    f.sequence = sequence_++;
    return f;
  }

 private:
  std::string id_;
  drivers::CameraSettings settings_;
  core::Image mono_, colour_;
  std::uint64_t sequence_ = 0;
};

double CpuSeconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_utime.tv_sec + u.ru_stime.tv_sec + 1e-6 * (u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// Args: cameras, frame rate in tenths of Hz, 1 for Mono12 (laser sweeps) or
// 0 for RGB12 (BTF images), and 1 to trigger each frame by software at the
// rate (as the capture runner does) or 0 to let the devices run free at it.
void BM_ServedCameras(benchmark::State& state) {
  const int cameras = static_cast<int>(state.range(0));
  const double rate_hz = state.range(1) / 10.0;
  const bool mono = state.range(2) == 1;
  const bool triggered = state.range(3) == 1;
  std::vector<std::unique_ptr<drivers::Camera>> still;
  std::vector<sim::ServedCameraAddress> addresses;
  for (int i = 0; i < cameras; ++i) {
    still.push_back(std::make_unique<StillCamera>("cam" + std::to_string(i)));
    addresses.push_back({"127.0.0." + std::to_string(i + 1), "cam" + std::to_string(i)});
  }
  sim::ServedCameras served(std::move(still), addresses);
  std::vector<std::unique_ptr<drivers::aravis::AravisCamera>> clients;
  for (int i = 0; i < cameras; ++i) {
    drivers::aravis::AravisCameraOptions o;
    o.id = "cam" + std::to_string(i);
    o.device = addresses[i].address;
    o.frame_rate_hz = rate_hz;
    o.packet_size = 8192;  // jumbo frames, as GigE Vision cameras are run
    clients.push_back(std::make_unique<drivers::aravis::AravisCamera>(o));
    clients.back()->SetPixelFormat(mono ? drivers::PixelFormat::kMono : drivers::PixelFormat::kNative);
    clients.back()->SetTrigger(triggered ? drivers::TriggerMode::kSoftware : drivers::TriggerMode::kFreeRun);
  }
  const auto period =
      std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(1.0 / rate_hz));
  const double seconds = 4.0;
  for (auto _ : state) {
    std::atomic<bool> stop{false};
    std::atomic<std::uint64_t> frames{0}, bytes{0};
    std::vector<std::uint64_t> dropped_before, sent_before;
    for (int i = 0; i < cameras; ++i) {
      if (triggered) clients[i]->Trigger();
      clients[i]->Grab(std::chrono::milliseconds(5000));  // streaming before the clock starts
      dropped_before.push_back(clients[i]->dropped_frames());
      sent_before.push_back(served.frames_served(i));
    }
    const double cpu0 = CpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<std::thread> threads;
    for (int i = 0; i < cameras; ++i) {
      threads.emplace_back([&, i] {
        auto next = std::chrono::steady_clock::now();
        while (!stop) {
          if (triggered) {
            std::this_thread::sleep_until(next);
            next += period;
            clients[i]->Trigger();
          }
          const drivers::Frame f = clients[i]->Grab(std::chrono::milliseconds(5000));
          ++frames;
          bytes += f.image.size() * 2;  // 12-bit values in 16-bit containers on the wire
        }
      });
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    stop = true;
    for (auto& t : threads) t.join();
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double cpu = CpuSeconds() - cpu0;
    std::uint64_t dropped = 0, sent = 0;
    for (int i = 0; i < cameras; ++i) {
      dropped += clients[i]->dropped_frames() - dropped_before[i];
      sent += served.frames_served(i) - sent_before[i];
    }
    state.SetIterationTime(wall);
    state.counters["fps_sent"] = sent / wall;
    state.counters["fps_received"] = frames / wall;
    state.counters["MB_per_s"] = bytes / wall / 1e6;
    state.counters["dropped"] = static_cast<double>(dropped);
    state.counters["cpu_ms_per_frame"] = frames ? 1e3 * cpu / frames : 0.0;
    state.counters["packet_size"] = clients[0]->packet_size();
  }
}

BENCHMARK(BM_ServedCameras)
    ->ArgNames({"cameras", "rate_x10", "mono", "triggered"})
    ->Args({1, 75, 1, 0})
    ->Args({1, 75, 0, 0})
    ->Args({1, 300, 1, 0})
    ->Args({1, 300, 0, 0})
    ->Args({8, 75, 1, 0})
    ->Args({8, 75, 0, 0})
    ->Args({8, 75, 1, 1})
    ->Args({8, 75, 0, 1})
    ->Iterations(1)
    ->UseManualTime()
    ->Unit(benchmark::kSecond);

}  // namespace
}  // namespace mesocap

BENCHMARK_MAIN();
