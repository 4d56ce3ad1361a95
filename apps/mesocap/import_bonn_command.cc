// `mesocap import bonn --in PATH --out MATERIAL --d-max-mm D`: reads a Bonn
// BTF database form (a UBO2003 image folder, or a UBO2014 FMF/DFMF file told
// by its signature) into a material package with the BTF, its ambient term
// and, on request, a flat MDF (pipelines/import_bonn.h).
#include <spdlog/spdlog.h>

#include <map>
#include <string>

#include "apps/mesocap/command.h"
#include "apps/mesocap/help_text.h"
#include "formats/material_manifest.h"
#include "pipelines/import_bonn.h"

namespace mesocap {

void RegisterImportBonnCommand(CLI::App& app) {
  auto o = std::make_shared<pipelines::ImportBonnOptions>();
  auto parts = std::make_shared<pipelines::BonnImportParts>(pipelines::BonnImportParts::kFactored);
  CLI::App* group = GroupCommand(app, "import", "Read another tool's format into a material package");
  CLI::App* sub = group->add_subcommand("bonn", HelpText("import_bonn"));
  sub->add_option("--in", o->in, "image folder (tl..._pl..._tv..._pv....png/.exr) or FMF/DFMF file")
      ->required()
      ->check(CLI::ExistingPath);
  sub->add_option("--out", o->out, "material package folder to write")->required();
  sub->add_option("--d-max-mm", o->d_max_mm,
                  "mesostructure depth of the material, mm (required: the Bonn forms carry none)")
      ->required()
      ->check(InRange(pipelines::kMinBonnLengthMm, pipelines::kMaxBonnDMaxMm));
  sub->add_option("--size-mm", o->width_mm,
                  "physical width of the texture, mm (default for FMF/DFMF: width / the file's pixels per mm)")
      ->check(InRange(pipelines::kMinBonnLengthMm, pipelines::kMaxBonnWidthMm));
  using pipelines::BonnImportParts;
  const std::map<std::string, BonnImportParts> part_names{
      {"factored", BonnImportParts::kFactored}, {"full", BonnImportParts::kFull}, {"both", BonnImportParts::kBoth}};
  CLI::Option* parts_option =
      sub->add_option("--btf", *parts,
                      "BTF forms to write: factored (default for FMF/DFMF), full (default and only choice for images) "
                      "or both")
          ->transform(NamedChoice(part_names));
  sub->add_option("--scale", o->scale, "images: reflectance = image value / scale")
      ->check(InRange(bonn::kMinUbo2003Scale, bonn::kMaxUbo2003Scale))
      ->capture_default_str();
  sub->add_flag("--flat-mdf", o->flat_mdf,
                "add an MDF of distance 0 everywhere (the surface taken as the flat reference plane), "
                "so the renderer can show the BTF");
  sub->add_option("--name", o->name, "material name (default: the input's name)");
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->callback([o, parts, parts_option] {
    if (parts_option->count() > 0) o->parts = *parts;
    const pipelines::ImportBonnReport r = pipelines::RunImportBonn(*o);
    const formats::MaterialDescription& d = r.manifest.description;
    spdlog::info("wrote {} from the {} {}: {}x{} texels, {} views x {} lights{}{} ({:.2f} s)", o->out.string(),
                 ToString(r.form), r.signature.empty() ? "folder" : r.signature, d.width, d.height,
                 d.view_directions.size(), d.light_directions.size(), r.manifest.full_btf ? ", full BTF" : "",
                 r.rank > 0 ? ", factored BTF of rank " + std::to_string(r.rank) : std::string(), r.seconds);
  });
}

}  // namespace mesocap
