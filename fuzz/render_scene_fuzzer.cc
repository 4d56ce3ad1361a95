// Drives render::ReadRenderScene with the input as a scene file. Every
// material a scene names resolves to one fixed material (packages have
// fuzzers of their own); an OBJ shape may name mesh.obj, fuzz::TinyObjText.
#include "fuzz/fuzz_input.h"
#include "fuzz/tiny_instances.h"
#include "render/render_scene.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace mesocap;
  static const bool mesh_written = [] {
    fuzz::WriteFileBytes(fuzz::ScratchDir() / "mesh.obj", fuzz::TinyObjText());
    return true;
  }();
  (void)mesh_written;
  const std::filesystem::path file = fuzz::ScratchDir() / "scene.json";
  fuzz::WriteFileBytes(file, fuzz::Bytes(data, size));
  const render::MaterialResolver resolver = [](const std::string& spec, const std::filesystem::path&) {
    render::RenderMaterial material;
    material.name = spec;
    material.sample_size_mm = 10.0;
    material.d_max_mm = 1.0;
    return material;
  };
  return fuzz::ReadRejectingOnlyWithError([&] { render::ReadRenderScene(file, resolver); });
}
