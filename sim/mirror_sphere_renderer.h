// Photos of the rig's mirror sphere (formats/rig_description.h) as a camera
// of the simulated rig takes them, for the lamps' calibration
// (calibration/light_arc_calibration.h): a perfect mirror of the
// description's reflectance in its cup at the sample centre, each lamp that
// is on a sphere of uniform radiance I / (pi r_e^2) about its true position
// (its irradiance is then exactly a point lamp's, as the BTF images assume),
// and a dark rig around them. Rays through the camera's exact model
// (sim/camera_renderer.h), supersampled on the pixels near the sphere;
// Embree intersects the sphere and the emitters. The signal is at the
// camera's description exposure and 0 dB, as FrameRenderer's; the sensor
// comes after.
#pragma once

#include <vector>

#include "core/error.h"
#include "core/image.h"
#include "formats/calibration.h"
#include "formats/rig_description.h"
#include "sim/undistorted_grid.h"

namespace mesocap::sim {

struct MirrorSpherePhotoOptions {
  // A lamp's mirror image is one to a few pixels across on the shipped rigs:
  // its centroid needs the pixels' area averaged finely.
  int samples_per_pixel_side = 8;  // 1..32
  core::CheckResult Check() const;
};

// Camera `camera`'s photo (RGB linear signal, fraction of full scale) with
// the turntable at turntable_rad (the sphere's cup turns with it), the
// light arc at arc_rad and the lamps lamps_on[i] on. `truth` gives the
// cameras, turntable, arc and lamps. Throws Error when the rig has no
// mirror_sphere. `grid` and `centres`, when given, hold the camera's
// undistorted samples over (at least) MirrorSpherePixels at the options' samples per
// pixel side and at the pixels' centres (1 per side).
core::Image RenderMirrorSpherePhoto(const formats::RigDescription& rig, const formats::Calibration& truth, int camera,
                                    double turntable_rad, double arc_rad, const std::vector<bool>& lamps_on,
                                    const MirrorSpherePhotoOptions& options = {}, const UndistortedGrid* grid = nullptr,
                                    const UndistortedGrid* centres = nullptr);

// The pixels a photo of the sphere looks at (the rest of the image is dark):
// a square about the sphere's image. Throws Error when the rig has no
// mirror_sphere.
PixelRect MirrorSpherePixels(const formats::RigDescription& rig, const formats::Calibration& truth, int camera,
                             double turntable_rad);

}  // namespace mesocap::sim
