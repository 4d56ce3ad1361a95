// `mesocap import bonn --in PATH --out MATERIAL --d-max-mm D`: reads a Bonn
// BTF database form (a UBO2003 image folder, or a UBO2014 FMF/DFMF file told
// by its signature) into a material package with the BTF, its ambient term
// and, on request, a flat MDF (processing/bonn_interop.h).
#include <spdlog/spdlog.h>

#include <filesystem>
#include <map>

#include "apps/mesocap/command.h"
#include "interop/bonn/bonn_interop.h"

namespace mesocap {
namespace {

struct ImportBonnCommandOptions {
  std::filesystem::path in;
  std::filesystem::path out;
  bonn::BonnImportOptions bonn;
  bonn::BonnImportParts parts = bonn::BonnImportParts::kFactored;  // used when --btf is given
};

void RunImportBonn(const ImportBonnCommandOptions& o) {
  const bonn::BonnImportReport r = bonn::ImportBonn(o.in, o.out, o.bonn);
  const formats::MaterialDescription& d = r.manifest.description;
  spdlog::info("wrote {} from the {} {}: {}x{} texels, {} views x {} lights{}{} ({:.2f} s)", o.out.string(),
               ToString(r.form), r.signature.empty() ? "folder" : r.signature, d.width, d.height,
               d.view_directions.size(), d.light_directions.size(), r.manifest.full_btf ? ", full BTF" : "",
               r.rank > 0 ? ", factored BTF of rank " + std::to_string(r.rank) : std::string(), r.seconds);
}

}  // namespace

void RegisterImportBonnCommand(CLI::App& app) {
  auto o = std::make_shared<ImportBonnCommandOptions>();
  CLI::App* group = GroupCommand(app, "import", "Read another tool's format into a material package");
  CLI::App* sub = group->add_subcommand(
      "bonn", "Read a Bonn BTF database form (UBO2003 image folder, UBO2014 FMF/DFMF file) into a material package");
  sub->add_option("--in", o->in, "image folder (tl..._pl..._tv..._pv....png/.exr) or FMF/DFMF file")
      ->required()
      ->check(CLI::ExistingPath);
  sub->add_option("--out", o->out, "material package folder to write")->required();
  sub->add_option("--d-max-mm", o->bonn.d_max_mm,
                  "mesostructure depth of the material, mm (required: the Bonn forms carry none)")
      ->required()
      ->check(CLI::PositiveNumber);
  sub->add_option("--size-mm", o->bonn.width_mm,
                  "physical width of the texture, mm (default for FMF/DFMF: width / the file's pixels per mm)")
      ->check(CLI::PositiveNumber);
  const std::map<std::string, bonn::BonnImportParts> parts{
      {"factored", bonn::BonnImportParts::kFactored}, {"full", bonn::BonnImportParts::kFull}, {"both", bonn::BonnImportParts::kBoth}};
  CLI::Option* parts_option = sub->add_option("--btf", o->parts,
                  "BTF forms to write: factored (default for FMF/DFMF), full (default and only choice for images) "
                  "or both")
      ->transform(CLI::CheckedTransformer(parts, CLI::ignore_case));
  sub->add_option("--scale", o->bonn.scale, "images: reflectance = image value / scale")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  sub->add_flag("--flat-mdf", o->bonn.flat_mdf,
                "add an MDF of distance 0 everywhere (the surface taken as the flat reference plane), "
                "so the renderer can show the BTF");
  sub->add_option("--name", o->bonn.name, "material name (default: the input's name)");
  sub->add_flag("--replace", o->bonn.replace, "replace an existing package at --out");
  sub->callback([o, parts_option] {
    if (parts_option->count() > 0) o->bonn.parts = o->parts;
    RunImportBonn(*o);
  });
}

}  // namespace mesocap
