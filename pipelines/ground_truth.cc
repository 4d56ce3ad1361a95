#include "pipelines/ground_truth.h"

#include <spdlog/spdlog.h>

#include "calibration/nominal_geometry.h"
#include "core/atomic_file.h"
#include "core/image.h"
#include "formats/material_manifest.h"
#include "formats/material_package_writer.h"
#include "interop/bonn/ubo_sampling_sets.h"
#include "sim/ground_truth.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"

namespace mesocap::pipelines {
namespace {

// `flag` names the option for messages ("--views").
core::SamplingSet DirectionSet(const std::string& name, const core::SamplingSet& rig_set, const char* flag) {
  if (name == "rig") return rig_set;
  try {
    return bonn::NamedSamplingSet(name);
  } catch (const core::Error& e) {
    throw core::Error(std::string(flag) + ": " + e.what());
  }
}

}  // namespace

core::CheckResult GroundTruthOptions::Check() const {
  if (out.empty()) return "out: give the material package folder to write";
  if (texture_size < 1 || texture_size > core::kMaxImageSide) {
    return "texture_size " + std::to_string(texture_size) + " must be 1.." + std::to_string(core::kMaxImageSide);
  }
  if (texel_samples_per_side < 1 || texel_samples_per_side > formats::kMaxTexelSamplesPerSide) {
    return "texel_samples_per_side " + std::to_string(texel_samples_per_side) + " must be 1.." +
           std::to_string(formats::kMaxTexelSamplesPerSide);
  }
  return {};
}

GroundTruthReport RunGroundTruth(const GroundTruthOptions& o) {
  core::ThrowIfInvalid(o.Check(), "groundtruth");
  core::ExpectReplaceable(o.out, formats::PackageReplacement(o.replace, {o.scene.scene, o.rig}));
  const auto scene = sim::LoadScene(o.scene);
  const formats::RigDescription rig = sim::LoadRig(o.rig);
  sim::GroundTruthOptions gt;
  gt.texels.width = gt.texels.height = o.texture_size;
  gt.texels.sample_size_mm = rig.sample_size_mm;
  gt.views = DirectionSet(o.views, calibration::ViewDirections(rig), "--views");
  gt.lights = DirectionSet(o.lights, calibration::LightDirections(rig), "--lights");
  gt.samples_per_side = o.texel_samples_per_side;
  core::ThrowIfInvalid(gt.Check(), "groundtruth");
  const formats::Calibration calibration = sim::TrueCalibration(rig);
  spdlog::info("ground truth of scene {} on rig {}: {}x{} texels ({}x{} samples each), {} views x {} lights",
               scene->name(), rig.name, gt.texels.width, gt.texels.height, gt.samples_per_side, gt.samples_per_side,
               gt.views.size(), gt.lights.size());
  sim::WriteGroundTruthPackage(*scene, gt, &calibration, "groundtruth scene=" + scene->name() + " rig=" + rig.name,
                               o.out, o.replace);
  return {scene->name(), rig.name};
}

}  // namespace mesocap::pipelines
