// Drives formats::ReadSessionManifest with the input as a session's
// manifest.json, then, as the capture runner does, the rig snapshot
// (ParseRigDescription) and every plan step (ReadCaptureStep).
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/rig_description.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  const std::filesystem::path dir = fuzz::ScratchDir();
  const std::filesystem::path file = dir / formats::kSessionManifestName;
  fuzz::WriteFileBytes(file, fuzz::Bytes(data, size));
  return fuzz::ReadRejectingOnlyWithError([&] {
    const formats::SessionManifest manifest = formats::ReadSessionManifest(dir);
    const formats::RigDescription rig = formats::ParseRigDescription(manifest.rig, file);
    for (std::size_t s = 0; s < manifest.plan.size(); ++s) formats::ReadCaptureStep(manifest.plan[s], s, rig, file);
  });
}
