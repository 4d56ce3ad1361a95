#include "sim/served_cameras.h"

#include <arpa/inet.h>
#include <arv.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <span>
#include <thread>

#include "core/error.h"
#include "drivers/aravis/pixel_format.h"
#include "drivers/device_error.h"
#include "sim/simulated_rig_backend.h"

namespace mesocap::sim {
namespace {

namespace fs = std::filesystem;
using drivers::aravis::PixelFormatTraits;

// GigE Vision bootstrap registers hold a 16-byte serial number string.
constexpr std::size_t kMaxSerialLength = 15;
// A served camera sends a rendered frame within 5 ms instead of at the fake
// device's default 25 Hz trigger clock.
constexpr double kTriggerPollHz = 200.0;
// The client's TriggerSoftware command is redirected to this otherwise unused
// register of the fake device's memory, which the server's own render thread
// watches: the device's thread answers the control channel, and a frame that
// takes seconds to render must not keep it from answering (Aravis declares a
// device gone after its control channel is silent for a few retries).
constexpr guint32 kRedirectedTriggerRegister = 0x8000;
// The client's AcquisitionStart is redirected the same way: the render
// thread drops what it made for the stopped acquisition, then starts the
// device. A real camera drops at AcquisitionStop what it has not sent;
// without this, a frame made for a trigger that timed out just before the
// client stopped the stream would answer the first trigger after the restart.
constexpr guint32 kRedirectedAcquisitionStartRegister = 0x8004;
// A TriggerSoftware command writes the token the client read from here
// (GenICam's pCommandValue), and the render thread moves the token on at
// each trigger it takes. A command the client sent again because its
// acknowledgement came late (GVCP retries a write after 500 ms; the fake
// device executes every copy) writes a spent token and is ignored: one frame
// a trigger, not a second one that would answer the client's next trigger
// with the scene before it.
constexpr guint32 kTriggerTokenRegister = 0x8008;
// How often the render thread looks at those registers.
constexpr auto kTriggerWatchPeriod = std::chrono::milliseconds(1);

bool IsIpv4Address(const std::string& s) {
  in_addr address{};
  return inet_pton(AF_INET, s.c_str(), &address) == 1;
}

std::vector<PixelFormatTraits> ServedFormats(const drivers::CameraInfo& info) {
  std::vector<PixelFormatTraits> formats;
  for (const auto& f : drivers::aravis::SupportedPixelFormats()) {
    if (f.bayer != drivers::aravis::BayerPattern::kNone || f.bit_depth != info.bit_depth) continue;
    if (f.channels == 1 || f.channels == info.channels) formats.push_back(f);
  }
  if (formats.empty()) {
    throw core::Error("camera " + info.id + ": no GigE Vision pixel format carries " + std::to_string(info.bit_depth) +
                      "-bit values (served bit depths: 8, 10, 12, 16 mono; 8, 10, 12 RGB)");
  }
  return formats;
}

// In `text`, the first `from` after `anchor` becomes `to`; an Error naming
// `what` when either is missing.
void ReplaceAfter(std::string& text, const std::string& anchor, const std::string& from, const std::string& to,
                  const std::string& what) {
  const auto at = text.find(anchor);
  const auto found = at == std::string::npos ? std::string::npos : text.find(from, at);
  if (found == std::string::npos) throw core::Error("Aravis' fake camera has no " + what + " to redirect");
  text.replace(found, from.size(), to);
}

std::string Hex(guint32 value) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%x", value);
  return text;
}

// A 4-byte big-endian register of the device's memory, for the GenICam description.
std::string IntReg(const std::string& name, guint32 address, const std::string& access) {
  return "<IntReg Name=\"" + name + "\" NameSpace=\"Custom\"><Address>" + Hex(address) +
         "</Address><Length>4</Length><AccessMode>" + access +
         "</AccessMode><Cachable>NoCache</Cachable><pPort>Device</pPort><Sign>Unsigned</Sign>"
         "<Endianess>BigEndian</Endianess></IntReg>\n\t";
}

// The fake device's own GenICam description, with its PixelFormat entries
// replaced by `formats` (the register behind them takes any PFNC code, and
// the payload follows the code's bits a pixel), and the commands the render
// thread acts on redirected to registers of its own: TriggerSoftware, whose
// value is the trigger token, and AcquisitionStart.
std::string GenICamDescription(const std::vector<PixelFormatTraits>& formats) {
  ArvFakeCamera* reference = arv_fake_camera_new("reference");
  size_t size = 0;
  const char* xml = arv_fake_camera_get_genicam_xml(reference, &size);
  std::string text(xml ? xml : "", xml ? size : 0);
  g_object_unref(reference);
  const auto enumeration = text.find("<Enumeration Name=\"PixelFormat\"");
  const auto first = text.find("<EnumEntry", enumeration);
  const auto value = text.find("<pValue>", enumeration);
  if (enumeration == std::string::npos || first == std::string::npos || value == std::string::npos || first > value) {
    throw core::Error("Aravis' fake camera has no PixelFormat enumeration to serve formats through");
  }
  std::string entries;
  for (const auto& f : formats) {
    entries += "<EnumEntry Name=\"" + f.name + "\" NameSpace=\"Standard\"><Value>" + std::to_string(f.code) +
               "</Value></EnumEntry>\n\t\t";
  }
  text = text.substr(0, first) + entries + text.substr(value);

  const auto trigger_register = text.find("<IntReg Name=\"TriggerSoftwareCommandRegister\"");
  const auto address = text.find("<Address>", trigger_register);
  const auto address_end = text.find("</Address>", address);
  if (trigger_register == std::string::npos || address == std::string::npos || address_end == std::string::npos) {
    throw core::Error("Aravis' fake camera has no TriggerSoftwareCommandRegister to redirect");
  }
  text = text.substr(0, address + 9) + Hex(kRedirectedTriggerRegister) + text.substr(address_end);
  ReplaceAfter(text, "<Command Name=\"TriggerSoftware\"", "<CommandValue>1</CommandValue>",
               "<pCommandValue>TriggerSoftwareTokenRegister</pCommandValue>", "TriggerSoftware command");
  // AcquisitionStop still writes the device's acquisition register directly.
  ReplaceAfter(text, "<Command Name=\"AcquisitionStart\"", "<pValue>AcquisitionCommandRegister</pValue>",
               "<pValue>AcquisitionStartCommandRegister</pValue>", "AcquisitionStart command");
  const auto commands = text.find("<Command Name=\"AcquisitionStart\"");
  return text.substr(0, commands) + IntReg("TriggerSoftwareTokenRegister", kTriggerTokenRegister, "RO") +
         IntReg("AcquisitionStartCommandRegister", kRedirectedAcquisitionStartRegister, "WO") + text.substr(commands);
}

}  // namespace

// What a client set through the device's registers, read at a trigger.
struct ServedSettings {
  guint32 exposure_us = 0, gain = 0, pixel_format = 0;
  drivers::CameraRegion region;
  bool operator==(const ServedSettings& o) const {
    return exposure_us == o.exposure_us && gain == o.gain && pixel_format == o.pixel_format && region.x == o.region.x &&
           region.y == o.region.y && region.width == o.region.width && region.height == o.region.height;
  }
};

struct ServedCameras::Server {
  ServedCameraAddress address;
  std::unique_ptr<drivers::Camera> camera;
  std::vector<PixelFormatTraits> formats;
  std::mutex* render_mutex = nullptr;
  std::function<std::uint64_t()> scene_changes;
  ArvGvFakeCamera* device = nullptr;
  std::atomic<std::uint64_t> served{0};
  std::atomic<std::uint64_t> failed{0};

  // A frame made for a trigger: its payload, and false for a black frame
  // sent for a Grab that failed.
  struct Made {
    std::vector<std::byte> bytes;
    bool ok = true;
  };
  // The frame rendered for the latest software trigger, until the device's
  // thread sends it.
  std::mutex rendered_mutex;
  Made rendered;
  bool has_rendered = false;
  std::thread render_thread;
  std::atomic<bool> stop_rendering{false};
  // The last frame rendered for a trigger, with the scene and settings it
  // shows (render thread only).
  struct LastFrame {
    std::uint64_t scene_changes = 0;
    ServedSettings settings;
    Made frame;
  };
  std::optional<LastFrame> last;

  ~Server() { Stop(); }

  ArvFakeCamera* fake() const { return arv_gv_fake_camera_get_fake_camera(device); }

  std::uint32_t Register(std::uint32_t address_of) const {
    guint32 value = 0;
    arv_fake_camera_read_register(fake(), address_of, &value);
    return value;
  }

  ServedSettings Settings() const {
    ServedSettings s;
    s.exposure_us = Register(ARV_FAKE_CAMERA_REGISTER_EXPOSURE_TIME_US);
    s.gain = Register(ARV_FAKE_CAMERA_REGISTER_GAIN_RAW);
    s.pixel_format = Register(ARV_FAKE_CAMERA_REGISTER_PIXEL_FORMAT);
    s.region.x = static_cast<int>(Register(ARV_FAKE_CAMERA_REGISTER_X_OFFSET));
    s.region.y = static_cast<int>(Register(ARV_FAKE_CAMERA_REGISTER_Y_OFFSET));
    s.region.width = static_cast<int>(Register(ARV_FAKE_CAMERA_REGISTER_WIDTH));
    s.region.height = static_cast<int>(Register(ARV_FAKE_CAMERA_REGISTER_HEIGHT));
    return s;
  }

  void StartRendering() {
    stop_rendering = false;
    render_thread = std::thread([this] { WatchTriggers(); });
  }

  // Stops the render thread, then the device (which joins the device's threads).
  void Stop() {
    stop_rendering = true;
    if (render_thread.joinable()) render_thread.join();
    if (device) g_object_unref(device);
    device = nullptr;
    std::lock_guard lock(rendered_mutex);
    has_rendered = false;
  }

  // A client's software trigger lands in the redirected register: the frame
  // is made here, then the trigger passed on to the device, whose thread
  // sends it at its next frame-clock tick. A trigger with nothing changed
  // since the last one (a client that timed out and triggered again) sends
  // the same frame again: a late frame and its retry are one exposure, as a
  // frame lost in process draws no noise (SimulatedCamera), so the session
  // does not depend on when a client gave up waiting. An AcquisitionStart
  // drops the frame not yet sent (made for the stopped acquisition) and the
  // trigger the device has not acted on, then starts the device.
  void WatchTriggers() {
    std::optional<Made> unsent;
    while (!stop_rendering) {
      if (Register(kRedirectedAcquisitionStartRegister) != 0) {
        arv_fake_camera_write_register(fake(), kRedirectedAcquisitionStartRegister, 0);
        unsent.reset();
        {
          std::lock_guard lock(rendered_mutex);
          has_rendered = false;
          arv_fake_camera_write_register(fake(), ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, 0);
        }
        arv_fake_camera_write_register(fake(), ARV_FAKE_CAMERA_REGISTER_ACQUISITION, 1);
        continue;
      }
      if (unsent) {
        // The device sends one frame a trigger: the previous one must be sent.
        bool handed_over = false;
        {
          std::lock_guard lock(rendered_mutex);
          if (!has_rendered && Register(ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE) == 0) {
            rendered = std::move(*unsent);
            has_rendered = true;
            handed_over = true;
          }
        }
        if (!handed_over) {
          std::this_thread::sleep_for(kTriggerWatchPeriod);
          continue;
        }
        unsent.reset();
        arv_fake_camera_write_register(fake(), ARV_FAKE_CAMERA_REGISTER_TRIGGER_SOFTWARE, 1);
        continue;
      }
      const guint32 token = Register(kRedirectedTriggerRegister);
      if (token == 0) {
        std::this_thread::sleep_for(kTriggerWatchPeriod);
        continue;
      }
      arv_fake_camera_write_register(fake(), kRedirectedTriggerRegister, 0);
      if (token != Register(kTriggerTokenRegister)) continue;  // a copy of a trigger already taken
      arv_fake_camera_write_register(fake(), kTriggerTokenRegister, token == 0xffffffffu ? 1 : token + 1);
      if (!arv_fake_camera_is_in_software_trigger_mode(fake())) continue;  // a real device ignores it too
      const ServedSettings settings = Settings();
      const std::uint64_t changes = scene_changes ? scene_changes() : 0;
      if (scene_changes && last && last->scene_changes == changes && last->settings == settings) {
        unsent = last->frame;
        continue;
      }
      Made made;
      made.bytes.resize(arv_fake_camera_get_payload(fake()));
      made.ok = Render(made.bytes, settings);
      if (scene_changes) last = LastFrame{changes, settings, made};
      unsent = std::move(made);
    }
  }

  // Called on the device's thread for every frame it sends: the frame the
  // render thread made for this trigger, or, free running (no trigger), one
  // rendered here.
  static void Fill(ArvBuffer* buffer, void* self, guint32, guint32, ArvPixelFormat) {
    static_cast<Server*>(self)->FillFrame(buffer);
  }

  void FillFrame(ArvBuffer* buffer) {
    // The fill callback's contract: write the frame into this buffer. It
    // reports no size before it is filled; the device checked that it holds
    // the current payload before calling.
    auto* data = static_cast<std::byte*>(const_cast<void*>(arv_buffer_get_data(buffer, nullptr)));
    const std::span<std::byte> payload(data, arv_fake_camera_get_payload(fake()));
    std::optional<bool> sent_ok;
    {
      std::lock_guard lock(rendered_mutex);
      if (has_rendered && rendered.bytes.size() == payload.size()) {
        std::copy(rendered.bytes.begin(), rendered.bytes.end(), payload.begin());
        sent_ok = rendered.ok;
      }
      has_rendered = false;
    }
    if (!sent_ok) sent_ok = Render(payload, Settings());
    ++(*sent_ok ? served : failed);
  }

  // One Grab of the camera behind, with the settings the client wrote to the
  // device's registers, encoded in the served pixel format; false, and a
  // black frame, when the Grab failed.
  bool Render(std::span<std::byte> payload, const ServedSettings& wanted) {
    std::lock_guard lock(*render_mutex);
    try {
      const PixelFormatTraits* format = nullptr;
      for (const auto& f : formats) {
        if (f.code == wanted.pixel_format) format = &f;
      }
      if (format == nullptr)
        throw core::Error("pixel format " + std::to_string(wanted.pixel_format) + " is not served");
      const drivers::CameraSettings now = camera->settings();
      drivers::CameraRegion region = wanted.region;
      // The whole sensor is the interface's default region, {0, 0, 0, 0}.
      const drivers::CameraInfo info = camera->info();
      if (region.x == 0 && region.y == 0 && region.width == info.sensor_width && region.height == info.sensor_height) {
        region = {};
      }
      const auto mode =
          format->channels == 1 && info.channels != 1 ? drivers::PixelFormat::kMono : drivers::PixelFormat::kNative;
      if (now.exposure_us != wanted.exposure_us) camera->SetExposure(wanted.exposure_us);
      if (now.gain_db != wanted.gain) camera->SetGain(wanted.gain);
      if (now.region.x != region.x || now.region.y != region.y || now.region.width != region.width ||
          now.region.height != region.height) {
        camera->SetRegion(region);
      }
      if (now.pixel_format != mode) camera->SetPixelFormat(mode);
      if (now.trigger != drivers::TriggerMode::kSoftware) camera->SetTrigger(drivers::TriggerMode::kSoftware);
      camera->Trigger();
      const drivers::Frame frame = camera->Grab(std::chrono::milliseconds(0));
      drivers::aravis::EncodePixels(frame.image, *format, payload);
      return true;
    } catch (const std::exception&) {
      // The device sends a frame whatever happens here: a black one, counted.
      std::fill(payload.begin(), payload.end(), std::byte{0});
      return false;
    }
  }
};

std::vector<ServedCameraAddress> ServedAddresses(const formats::RigDescription& rig) {
  std::vector<ServedCameraAddress> addresses;
  for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
    const auto& c = rig.cameras[i];
    if (c.id.size() > kMaxSerialLength) {
      throw core::Error("camera " + core::Quoted(c.id) + ": a served camera's id is its GigE Vision serial number, " +
                        "at most 15 characters");
    }
    const bool own = c.backend == "aravis" && IsIpv4Address(c.device);
    addresses.push_back({own ? c.device : "127.0.0." + std::to_string(i + 1), c.id});
  }
  return addresses;
}

ServedCameras::ServedCameras(std::vector<std::unique_ptr<drivers::Camera>> cameras,
                             std::vector<ServedCameraAddress> addresses, std::function<std::uint64_t()> scene_changes) {
  if (cameras.size() != addresses.size()) throw core::Error("served cameras: one address per camera expected");
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    auto server = std::make_unique<Server>();
    server->address = addresses[i];
    server->camera = std::move(cameras[i]);
    server->render_mutex = &render_mutex_;
    server->scene_changes = scene_changes;
    server->formats = ServedFormats(server->camera->info());
    servers_.push_back(std::move(server));
    Serve(i);
  }
}

void ServedCameras::Serve(std::size_t i) {
  Server& server = *servers_.at(i);
  const drivers::CameraInfo info = server.camera->info();
  // Aravis reads the description from a file: write it, start the
  // device, and remove the file (the device keeps its contents).
  const fs::path xml =
      fs::temp_directory_path() / ("mesocap-served-" + std::to_string(::getpid()) + "-" + std::to_string(i) + ".xml");
  {
    std::ofstream out(xml, std::ios::binary | std::ios::trunc);
    out << GenICamDescription(server.formats);
    if (!out.flush()) throw core::Error("cannot write " + xml.string());
  }
  server.device =
      arv_gv_fake_camera_new_full(server.address.address.c_str(), server.address.serial.c_str(), xml.c_str());
  std::error_code ignored;
  fs::remove(xml, ignored);
  if (server.device == nullptr || !arv_gv_fake_camera_is_running(server.device)) {
    if (server.device) g_object_unref(server.device);
    server.device = nullptr;
    throw core::Error("camera " + info.id + ": cannot serve it at " + server.address.address +
                      ": not an address of this host's interfaces, or its GigE Vision port 3956 is taken (a "
                      "loopback address other than 127.0.0.1 must be added first: ip addr add " +
                      server.address.address + "/8 dev lo)");
  }
  ArvFakeCamera* fake = arv_gv_fake_camera_get_fake_camera(server.device);
  for (const auto& [reg, value] :
       {std::pair{ARV_FAKE_CAMERA_REGISTER_SENSOR_WIDTH, info.sensor_width},
        std::pair{ARV_FAKE_CAMERA_REGISTER_SENSOR_HEIGHT, info.sensor_height},
        std::pair{ARV_FAKE_CAMERA_REGISTER_WIDTH, info.sensor_width},
        std::pair{ARV_FAKE_CAMERA_REGISTER_HEIGHT, info.sensor_height},
        std::pair{ARV_FAKE_CAMERA_REGISTER_PIXEL_FORMAT, static_cast<int>(server.formats.back().code)},
        std::pair{ARV_FAKE_CAMERA_REGISTER_EXPOSURE_TIME_US,
                  static_cast<int>(std::lround(server.camera->settings().exposure_us))}}) {
    arv_fake_camera_write_register(fake, reg, static_cast<guint32>(value));
  }
  arv_fake_camera_write_register(fake, kTriggerTokenRegister, 1);  // 0 reads as no trigger
  arv_fake_camera_set_trigger_frequency(fake, kTriggerPollHz);
  arv_fake_camera_set_fill_pattern(fake, &Server::Fill, &server);
  server.StartRendering();
}

void ServedCameras::StopServing(std::size_t i) { servers_.at(i)->Stop(); }

void ServedCameras::ServeAgain(std::size_t i) {
  if (servers_.at(i)->device == nullptr) Serve(i);
}

ServedCameras::~ServedCameras() {
  // Stop every device before the cameras and the mutex their threads use go.
  for (auto& s : servers_) s->Stop();
}

const ServedCameraAddress& ServedCameras::address(std::size_t i) const { return servers_.at(i)->address; }
std::uint64_t ServedCameras::frames_served(std::size_t i) const { return servers_.at(i)->served; }
std::uint64_t ServedCameras::frames_failed(std::size_t i) const { return servers_.at(i)->failed; }

std::unique_ptr<ServedCameras> ServeRigCameras(const formats::RigDescription& rig, SimulatedRigBackend& backend) {
  std::vector<std::unique_ptr<drivers::Camera>> cameras;
  for (int i = 0; i < static_cast<int>(rig.cameras.size()); ++i) cameras.push_back(backend.MakeCamera(rig, i));
  return std::make_unique<ServedCameras>(std::move(cameras), ServedAddresses(rig),
                                         [state = backend.shared_state()] { return state->changes.load(); });
}

}  // namespace mesocap::sim
