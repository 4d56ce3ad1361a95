// `mesocap process btf --session S --calibration C --out MATERIAL
// [--rank K | --max-error E]`: the BTF of a capture session (Wang et al. 2005
// Sec. 3.1 and 5): every BTF image rectified into texture space, divided by
// its lamp's irradiance, placed on the session's view and light sets,
// factored by SVD; with the ambient term (Sec. 4.2) and the figures of each
// stage in the error report. Each camera's gain (signal per radiance second)
// is its calibration's radiometry unless --gain gives one for all.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <numbers>
#include <optional>

#include "apps/mesocap/command.h"
#include "btf/ambient_term.h"
#include "btf/btf_assembly.h"
#include "btf/btf_compression.h"
#include "calibration/nominal_geometry.h"
#include "core/error.h"
#include "formats/capture_session.h"
#include "formats/material_manifest.h"
#include "formats/material_package.h"
#include "formats/material_package_writer.h"
#include "formats/rig_description.h"

namespace mesocap {
namespace {

namespace fs = std::filesystem;

struct ProcessBtfCommandOptions {
  fs::path session;
  fs::path calibration;
  fs::path out;
  int texture_size = 64;
  double gain = 0.0;
  bool full = false;
  bool resample = false;
  bool replace = false;
  btf::BtfCompressionOptions compression;
};

void RunProcessBtf(const ProcessBtfCommandOptions& o) {
  const formats::SessionManifest manifest = formats::ReadSessionManifest(o.session);
  const formats::RigDescription rig = formats::ParseRigDescription(manifest.rig, o.session / formats::kSessionManifestName);
  fs::path calibration_file = o.calibration;
  if (calibration_file.empty()) {
    if (!manifest.calibration) throw core::Error("process btf: give --calibration (the session names none)");
    calibration_file = o.session / *manifest.calibration;
  }
  const formats::Calibration calibration = formats::ReadCalibration(calibration_file);

  btf::BtfAssemblyOptions a;
  a.texture_width = a.texture_height = o.texture_size;
  a.sample_size_mm = rig.sample_size_mm;
  a.views = calibration::ViewDirections(rig);
  a.lights = calibration::LightDirections(rig);
  a.resample = o.resample;
  for (const formats::CameraCalibration& camera : calibration.cameras) {
    const auto it = std::find_if(rig.cameras.begin(), rig.cameras.end(), [&](const auto& c) { return c.id == camera.id; });
    if (it == rig.cameras.end()) throw core::Error("process btf: calibrated camera " + camera.id + " is not in the rig");
    a.exposure_s.push_back(it->exposure_us * 1e-6);
    // The radiometric gain is the calibration's; --gain overrides it for all.
    if (o.gain > 0) {
      a.signal_per_radiance_second.push_back(o.gain);
    } else if (camera.radiometry) {
      a.signal_per_radiance_second.push_back(camera.radiometry->signal_per_radiance_second);
    } else {
      throw core::Error("process btf: " + calibration_file.string() + ": camera " + camera.id +
                  " has no radiometry.signal_per_radiance_second (its gain); calibrate it or give --gain G for "
                  "all cameras");
    }
  }
  const std::vector<btf::BtfCaptureImage> images = btf::SessionBtfImages(o.session, manifest, calibration);
  spdlog::info("assembling the BTF of {}: {} images, {} views x {} lights, {}x{} texels", o.session.string(),
               images.size(), a.views.size(), a.lights.size(), o.texture_size, o.texture_size);
  formats::MaterialDescription d;
  d.name = manifest.rig.value("name", "") + " session";
  d.width = d.height = o.texture_size;
  d.physical_size_mm = {rig.sample_size_mm, rig.sample_size_mm};
  // No geometry is measured here; d_max is a property of the MDF. The rig's
  // laser sweep range bounds it from above.
  d.d_max_mm = std::max(1e-3, rig.laser.sweep_max_mm - rig.laser.sweep_min_mm);
  d.view_directions = a.views;
  d.light_directions = a.lights;
  d.provenance.source = "process btf session=" + o.session.string();
  formats::MaterialPackageWriter writer(o.out, d, o.replace);

  // Each assembled view goes to disk as soon as it is made, and the SVD
  // streams it back in bands, so the BTF (1.5 GB of float for a paper rig at
  // 128 x 128) is never whole in memory. Without --full the views go to a
  // scratch package beside the output that is never committed: it is
  // removed when the command ends, however it ends.
  std::optional<formats::MaterialPackageWriter> scratch;
  if (!o.full) scratch.emplace(fs::path(o.out.string() + ".assembled"), d, true);
  formats::MaterialPackageWriter& views = o.full ? writer : *scratch;
  formats::AmbientTerm ambient = btf::MakeAmbientTerm(o.texture_size, o.texture_size, a.views);
  btf::BtfAssemblyReport assembly;
  btf::AssembleBtfViews(
      images, calibration, a,
      [&](int v, core::Image&& values) {
        btf::AddAmbientView(values, a.lights, v, &ambient);
        views.WriteFullBtfView(v, values);
      },
      &assembly);
  btf::BtfCompressionReport compression;
  const core::FactoredBtf factored = btf::CompressBtf(*views.ReadBackFullBtf(), o.compression, &compression);
  spdlog::info("rank {}: {}", compression.rank, compression.reason);
  scratch.reset();

  writer.WriteFactoredBtf(factored);
  writer.WriteAmbientTerm(ambient);
  writer.WriteCalibration(calibration);
  writer.WriteErrorReport({{"btf_assembly",
                            {{"images", assembly.images},
                             {"measured_pairs", assembly.measured_pairs},
                             {"interpolated_pairs", assembly.filled_pairs},
                             {"resampled", assembly.resampled},
                             {"extrapolated_views", assembly.extrapolated_views},
                             {"extrapolated_lights", assembly.extrapolated_lights},
                             {"max_view_offset_deg", assembly.max_view_offset_deg},
                             {"max_light_offset_deg", assembly.max_light_offset_deg},
                             {"max_samples_per_side", assembly.max_samples_per_side},
                             {"min_pixels_per_texel", assembly.min_pixels_per_texel}}},
                           {"btf_compression", ToJson(compression, factored)}});
  writer.Commit();
  spdlog::info("wrote {}", o.out.string());
}

}  // namespace

void RegisterProcessBtfCommand(CLI::App& app) {
  auto o = std::make_shared<ProcessBtfCommandOptions>();
  CLI::App* process = GroupCommand(app, "process", "Turn a capture session into a material");
  CLI::App* sub = process->add_subcommand("btf", "BTF, its SVD factors and ambient term from a capture session");
  sub->add_option("--session", o->session, "capture session folder")->required()->check(CLI::ExistingDirectory);
  sub->add_option("--calibration", o->calibration, "calibration file (default: the one the session names)")
      ->check(CLI::ExistingFile);
  sub->add_option("--out", o->out, "material package folder to write")->required();
  sub->add_option("--texture-size", o->texture_size, "texels per side")->check(CLI::Range(1, 4096))->capture_default_str();
  auto* rank = sub->add_option("--rank", o->compression.rank, "number of SVD terms, 1..100")
                   ->check(CLI::Range(1, core::kMaxBtfRank));
  sub->add_option("--max-error", o->compression.max_relative_error,
                  "error budget: the smallest rank whose relative RMS error is at most this")
      ->check(CLI::Range(1e-12, 1.0))
      ->capture_default_str()
      ->excludes(rank);
  sub->add_option("--gain", o->gain,
                  "camera signal (fraction of full scale) per radiance second, for every camera, overriding "
                  "the calibration's radiometry (default: each camera's from the calibration)")
      ->check(CLI::Range(formats::kMinCameraGain, formats::kMaxCameraGain));
  sub->add_flag("--full", o->full, "also store the full (uncompressed) BTF");
  sub->add_flag("--resample", o->resample,
                "resample captures whose directions are off the session's sets (each texel with its own view and "
                "light directions) instead of requiring them within 1 degree");
  sub->add_flag("--replace", o->replace, "replace an existing package at --out");
  sub->callback([o] { RunProcessBtf(*o); });
}

}  // namespace mesocap
