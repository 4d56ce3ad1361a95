#include "render/direction_blend_table.h"

#include <numbers>

namespace mesocap::render {

DirectionBlendTable MakeDirectionBlendTable(const core::SamplingSet& set, int phi_cells, int theta_cells) {
  DirectionBlendTable table;
  table.phi_cells = phi_cells;
  table.theta_cells = theta_cells;
  table.index.resize(static_cast<std::size_t>(phi_cells) * theta_cells);
  table.weight.resize(table.index.size());
  for (int t = 0; t < theta_cells; ++t) {
    for (int p = 0; p < phi_cells; ++p) {
      const double theta = (t + 0.5) * (std::numbers::pi / 2) / theta_cells;
      const double phi = (p + 0.5) * (2 * std::numbers::pi) / phi_cells;
      const core::SamplingSet::Blend blend = set.Interpolate(core::DirectionFromAngles(theta, phi));
      const std::size_t cell = static_cast<std::size_t>(t) * phi_cells + p;
      table.index[cell] = {0, 0, 0, 0};
      table.weight[cell] = {0, 0, 0, 0};
      for (int k = 0; k < blend.count; ++k) {
        table.index[cell][k] = blend.index[k];
        table.weight[cell][k] = static_cast<float>(blend.weight[k]);
      }
    }
  }
  return table;
}

}  // namespace mesocap::render
