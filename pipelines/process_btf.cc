#include "pipelines/process_btf.h"

#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <optional>
#include <vector>

#include "btf/ambient_term.h"
#include "btf/btf_assembly.h"
#include "btf/btf_evaluation.h"
#include "calibration/nominal_geometry.h"
#include "core/atomic_file.h"
#include "core/image.h"
#include "formats/calibration.h"
#include "formats/captured_session.h"
#include "formats/material_manifest.h"
#include "formats/material_package.h"
#include "formats/material_package_layout.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "formats/rig_description.h"

namespace mesocap::pipelines {
namespace {

namespace fs = std::filesystem;

// The assembly's figures as the error report's "btf_assembly" entry, with
// the pair record `eval btf` splits its figures by.
nlohmann::json ToJson(const btf::BtfAssemblyReport& assembly) {
  nlohmann::json out = {{"images", assembly.images},
                        {"measured_pairs", assembly.measured_pairs},
                        {"interpolated_pairs", assembly.filled_pairs},
                        {"resampled", assembly.resampled},
                        {"extrapolated_views", assembly.extrapolated_views},
                        {"extrapolated_lights", assembly.extrapolated_lights},
                        {"max_view_offset_deg", assembly.max_view_offset_deg},
                        {"max_light_offset_deg", assembly.max_light_offset_deg},
                        {"max_samples_per_side", assembly.max_samples_per_side},
                        {"min_pixels_per_texel", assembly.min_pixels_per_texel}};
  btf::AddPairRecord({assembly.measured, assembly.pixels_per_texel}, &out);
  return out;
}

// Each camera's exposure and radiometric gain, in the calibration's camera
// order: the gain is the calibration's unless `gain` overrides it for all.
void AddCameraRadiometry(const formats::RigDescription& rig, const formats::Calibration& calibration,
                         const fs::path& calibration_file, double gain, btf::BtfAssemblyOptions* a) {
  for (const formats::CameraCalibration& camera : calibration.cameras) {
    const auto it =
        std::find_if(rig.cameras.begin(), rig.cameras.end(), [&](const auto& c) { return c.id == camera.id; });
    if (it == rig.cameras.end()) {
      throw core::Error("process btf: calibrated camera " + camera.id + " is not in the rig");
    }
    a->exposure_s.push_back(it->exposure_us * 1e-6);
    if (gain > 0) {
      a->signal_per_radiance_second.push_back(gain);
    } else if (camera.radiometry) {
      a->signal_per_radiance_second.push_back(camera.radiometry->signal_per_radiance_second);
    } else {
      throw core::Error("process btf: " + calibration_file.string() + ": camera " + camera.id +
                        " has no radiometry.signal_per_radiance_second (its gain); calibrate it or give --gain G for "
                        "all cameras");
    }
  }
}

// The measured MDF a renderable material carries beside its BTF (MDF paper
// Sec. 4: both describe one sample). It must lie on the BTF's texel grid and
// view set; its d_max becomes the package's.
struct CarriedMdf {
  double d_max_mm = 0.0;
  core::Mdf mdf;
  formats::MdfForms forms;
  std::optional<core::Image> confidence;
};

std::optional<CarriedMdf> ReadCarriedMdf(const ProcessBtfOptions& o, const formats::MaterialDescription& d) {
  if (o.mdf.empty()) return std::nullopt;
  const formats::MaterialManifest manifest = formats::ReadMaterialManifest(o.mdf);
  const fs::path file = o.mdf / formats::kManifestFile;
  const formats::MaterialDescription& m = manifest.description;
  if (!manifest.mdf) throw core::FormatError(file, "mdf", "expected a package with an MDF (mesocap process mdf)");
  if (m.width != d.width || m.height != d.height) {
    throw core::FormatError(file, "width",
                            "expected the BTF's texture size " + std::to_string(d.width) + " (--texture-size), got " +
                                std::to_string(m.width) + "x" + std::to_string(m.height));
  }
  if ((m.physical_size_mm - d.physical_size_mm).norm() > 1e-6 * d.physical_size_mm.norm()) {
    throw core::FormatError(file, "physical_size_mm",
                            "expected the session's sample size " + core::Fixed(d.physical_size_mm.x(), 3) + " mm");
  }
  if (!m.view_directions.SameDirectionsAs(d.view_directions, 1e-6)) {
    throw core::FormatError(file, "view_directions", "expected the session's view directions (the same rig)");
  }
  CarriedMdf carried{m.d_max_mm, formats::ReadMdf(o.mdf, manifest), manifest.mdf->forms, std::nullopt};
  if (manifest.mdf->confidence) carried.confidence = formats::ReadMdfConfidence(o.mdf, manifest);
  return carried;
}

}  // namespace

core::CheckResult ProcessBtfOptions::Check() const {
  if (session.empty()) return "session: give the capture session folder";
  if (out.empty()) return "out: give the material package folder to write";
  if (texture_size < 1 || texture_size > core::kMaxImageSide) {
    return "texture_size " + std::to_string(texture_size) + " must be 1.." + std::to_string(core::kMaxImageSide);
  }
  if (gain != 0.0 && !(gain >= formats::kMinCameraGain && gain <= formats::kMaxCameraGain)) {
    return "gain must be 0 (each camera's from the calibration) or a camera gain in [1e-30, 1e30]";
  }
  return compression.Check();
}

ProcessBtfReport RunProcessBtf(const ProcessBtfOptions& o) {
  core::ThrowIfInvalid(o.Check(), "process btf");
  core::ExpectReplaceable(o.out, formats::PackageReplacement(o.replace, {o.session, o.calibration, o.mdf}));
  const formats::CapturedSession session(o.session, {o.allow_incomplete, "process btf"});
  if (!session.missing_steps().empty()) {
    spdlog::warn("{}: leaving out {} of {} planned steps, which the journal lacks (--allow-incomplete)",
                 o.session.string(), session.missing_steps().size(), session.manifest().plan.size());
  }
  const formats::SessionManifest& manifest = session.manifest();
  const formats::RigDescription rig = formats::ParseRigDescription(manifest.rig, session.manifest_file());
  const fs::path calibration_file = o.calibration.empty() ? session.IntactCalibrationFile() : o.calibration;
  const formats::Calibration calibration = formats::ReadCalibration(calibration_file);

  btf::BtfAssemblyOptions a;
  a.texels.width = a.texels.height = o.texture_size;
  a.texels.sample_size_mm = rig.sample_size_mm;
  a.views = calibration::ViewDirections(rig);
  a.lights = calibration::LightDirections(rig);
  a.resample = o.resample;
  AddCameraRadiometry(rig, calibration, calibration_file, o.gain, &a);
  const std::vector<btf::BtfCaptureImage> images = btf::SessionBtfImages(session, calibration);
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
  const std::optional<CarriedMdf> mdf = ReadCarriedMdf(o, d);
  if (mdf) {
    d.d_max_mm = mdf->d_max_mm;
    d.provenance.source += " mdf=" + o.mdf.string();
  }
  // Held at once: the ambient term, and per view being assembled (one per
  // worker) its float RGB image, its rectifier (at least 4 taps of 8 bytes
  // and an index per texel) and two rectified textures.
  const std::uint64_t texels = static_cast<std::uint64_t>(o.texture_size) * o.texture_size;
  const auto in_flight =
      static_cast<std::uint64_t>(std::clamp(tbb::this_task_arena::max_concurrency(), 1, std::max(1, a.views.size())));
  core::CheckMemoryFor(12 * texels * a.views.size() + in_flight * texels * (12 * a.lights.size() + 36 + 24),
                       "assembling the BTF at " + std::to_string(o.texture_size) + "x" +
                           std::to_string(o.texture_size) + " texels (--texture-size), " +
                           std::to_string(a.views.size()) + " views x " + std::to_string(a.lights.size()) +
                           " lights, " + std::to_string(in_flight) + " views at a time");
  formats::MaterialPackageWriter writer(o.out, d, o.replace, {o.session, calibration_file, o.mdf});

  // Each assembled view goes to disk as soon as it is made, so assembly
  // never holds the BTF (a paper rig's: docs/FORMATS.md, "The full BTF"); the
  // compression reads it back, whole where it chooses a representation (see
  // btf/btf_compression.h). Without `full` the views go to a
  // scratch package beside the output that is never committed: it is
  // removed when the job ends, however it ends.
  std::optional<formats::MaterialPackageWriter> scratch;
  if (!o.full) scratch.emplace(fs::path(o.out.string() + ".assembled"), d, true, std::vector<fs::path>{o.session});
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
  ProcessBtfReport report;
  report.images = assembly.images;
  const core::FactoredBtf factored = btf::CompressBtf(*views.ReadBackFullBtf(), o.compression, &report.compression);
  if (!report.compression.representation_reason.empty()) spdlog::info("{}", report.compression.representation_reason);
  spdlog::info("{} {}, rank {}: {}", ToString(factored.layout), ToString(factored.color), report.compression.rank,
               report.compression.reason);
  scratch.reset();

  writer.WriteFactoredBtf(factored);
  if (mdf) {
    writer.WriteMdf(mdf->mdf, mdf->forms);
    if (mdf->confidence) writer.WriteMdfConfidence(*mdf->confidence);
  }
  writer.WriteAmbientTerm(ambient);
  writer.WriteCalibration(calibration);
  writer.WriteErrorReport(
      {{"btf_assembly", ToJson(assembly)}, {"btf_compression", ToJson(report.compression, factored)}});
  writer.Commit();
  return report;
}

}  // namespace mesocap::pipelines
