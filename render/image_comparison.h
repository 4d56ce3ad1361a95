// Error of a rendering against the CPU reference (the paper's Table 2 figures):
// intersection over union of masks (coverage: mesostructure silhouettes;
// shadow: shadow silhouettes) and PSNR of the images.
#pragma once

#include "core/image.h"

namespace mesocap::render {

// |A and B| / |A or B| of the pixels above 0.5 in channel 0; 1 when both
// masks are empty. Throws Error when the sizes differ.
double MaskIou(const core::Image& a, const core::Image& b);

// 10 log10(1 / MSE) over all channels, values clamped to [0, 1] first (the
// displayable range at the scene's exposure); capped at 100 dB for equal
// images. Throws Error when the sizes or channel counts differ.
double Psnr(const core::Image& a, const core::Image& b);

// Where two masks disagree, for a person to look at: red where only `truth`
// is set, green where only `rendered` is, over a dim grey copy of
// `background` (channel 0) so the places can be recognized. Throws Error
// when the sizes differ.
core::Image MaskDifference(const core::Image& rendered, const core::Image& truth, const core::Image& background);

}  // namespace mesocap::render
