#include "drivers/aravis/aravis_rig_backend.h"

#include <spdlog/spdlog.h>

#include "drivers/aravis/aravis_camera.h"
#include "drivers/device_error.h"

namespace mesocap::drivers::aravis {

std::unique_ptr<Camera> AravisRigBackend::MakeCamera(const formats::RigDescription& rig, int camera_index) {
  const auto& description = rig.cameras.at(camera_index);
  AravisCameraOptions options;
  options.id = description.id;
  options.device = description.device;
  options.stream_ports = stream_ports_;
  auto camera = std::make_unique<AravisCamera>(options);
  // The description's sensor is what calibration and processing assume.
  const CameraInfo info = camera->info();
  if (info.sensor_width != description.width || info.sensor_height != description.height) {
    throw DeviceError("camera " + description.id + " (" + description.device + "): its sensor is " +
                      std::to_string(info.sensor_width) + " x " + std::to_string(info.sensor_height) + ", the rig " +
                      rig.file.string() + " says image_size " + std::to_string(description.width) + " x " +
                      std::to_string(description.height));
  }
  camera->SetExposure(description.exposure_us);
  return camera;
}

void ReopenGoneCameras(Rig& rig) {
  for (const std::unique_ptr<Camera>& camera : rig.cameras) {
    auto* gige = dynamic_cast<AravisCamera*>(camera.get());
    if (gige == nullptr || gige->IsConnected()) continue;
    try {
      gige->Reopen();
      spdlog::info("camera {}: answers again, reopened", gige->info().id);
    } catch (const DeviceError& e) {
      spdlog::debug("camera {}: still gone: {}", gige->info().id, e.what());
    }
  }
}

}  // namespace mesocap::drivers::aravis
