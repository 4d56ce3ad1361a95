#include "render/render_material.h"

#include <cmath>
#include <string>

#include "core/error.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"

namespace mesocap::render {

RenderMaterial LoadRenderMaterial(const std::filesystem::path& package) {
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(package);
  const std::filesystem::path file = package / "manifest.json";
  if (!manifest.factored_btf) {
    throw core::FormatError(file, "factored_btf",
                            manifest.full_btf
                                ? "the renderer needs the SVD-factored BTF; this package has only the full "
                                  "BTF (run `mesocap compress` first)"
                                : "the renderer needs the SVD-factored BTF; the package has none");
  }
  if (!manifest.mdf) throw core::FormatError(file, "mdf", "the renderer needs the MDF; the package has none");
  if (!manifest.ambient)
    throw core::FormatError(file, "ambient", "the renderer needs the ambient term; the package has none");
  const Eigen::Vector2d size = manifest.description.physical_size_mm;
  if (std::abs(size.x() - size.y()) > 1e-6 * size.x()) {
    throw core::FormatError(file, "physical_size_mm",
                            "the renderer maps square samples onto meshes; got " + std::to_string(size.x()) + " x " +
                                std::to_string(size.y()) + " mm");
  }
  RenderMaterial material;
  material.name = manifest.description.name;
  material.package = package;
  material.sample_size_mm = manifest.description.physical_size_mm.x();
  material.d_max_mm = manifest.description.d_max_mm;
  material.btf = formats::ReadFactoredBtf(package, manifest);
  material.mdf = formats::ReadMdf(package, manifest);
  material.ambient = formats::ReadAmbientTerm(package, manifest);
  return material;
}

}  // namespace mesocap::render
