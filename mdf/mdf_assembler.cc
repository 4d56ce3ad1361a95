#include "mdf/mdf_assembler.h"

#include <string>

namespace mesocap::mdf {

MdfAssembler::MdfAssembler(calibration::TexelGrid grid, core::SamplingSet views, TriangulationOptions triangulation,
                           MergeOptions merge)
    : grid_(grid), views_(std::move(views)), triangulation_(triangulation), merge_(merge) {
  for (const auto& problem : {grid_.Check(), triangulation_.Check(), merge_.Check()}) {
    core::ThrowIfInvalid(problem, "MDF assembly");
  }
  if (views_.size() < 1) throw core::Error("MDF assembly: the view set is empty");
  images_.resize(views_.size());
  weights_.resize(views_.size());
}

void MdfAssembler::AddSweep(int view, const formats::SweepAnalysis& analysis, const calibration::CameraRays& rays,
                            const core::RigidTransform& world_from_sample, double weight) {
  if (view < 0 || view >= views_.size())
    throw core::Error("MDF assembly: view " + std::to_string(view) + " out of range");
  const SweepPoints points = TriangulateSweep(analysis, rays, world_from_sample, triangulation_);
  AddDisplacementImage(
      view, ResampleToTexture(points, analysis.width, analysis.height, views_.direction(view), grid_, triangulation_),
      weight);
}

void MdfAssembler::AddDisplacementImage(int view, DisplacementImage image, double weight) {
  if (view < 0 || view >= views_.size())
    throw core::Error("MDF assembly: view " + std::to_string(view) + " out of range");
  if (image.width != grid_.width || image.height != grid_.height) {
    throw core::Error("MDF assembly: displacement image size differs from the texture grid");
  }
  if (!(weight > 0)) return;  // a scan with zero weight (camera in the laser plane) carries no information
  images_[view].push_back(std::move(image));
  weights_[view].push_back(weight);
}

core::Mdf MdfAssembler::Finish(core::Image* confidence) const {
  core::Mdf mdf = core::MakeMdf(grid_.width, grid_.height, views_);
  if (confidence) *confidence = core::Image(grid_.width, grid_.height * views_.size(), 1, 0.0f);
  for (int v = 0; v < views_.size(); ++v) {
    if (images_[v].empty()) continue;
    const MergedDisplacement merged = MergeDisplacementImages(images_[v], weights_[v], grid_.texel_width_mm(), merge_);
    for (int j = 0; j < grid_.height; ++j) {
      for (int i = 0; i < grid_.width; ++i) {
        const std::size_t p = static_cast<std::size_t>(j) * grid_.width + i;
        mdf.at(i, j, v) = merged.image.distance_mm[p];
        if (confidence) confidence->at(i, v * grid_.height + j) = merged.confidence[p];
      }
    }
  }
  return mdf;
}

}  // namespace mesocap::mdf
