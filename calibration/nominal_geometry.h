// The nominal geometry a rig description implies (MDF paper Sec. 3.1, Fig.
// 3a): device positions in the world frame, the rig's view and light
// directions in the sample frame, and the laser planes at tilt 0. The
// simulated rig takes it as the truth; calibration starts from it.
#pragma once

#include <Eigen/Core>

#include "core/sampling_set.h"
#include "formats/calibration.h"
#include "formats/rig_description.h"

namespace mesocap::calibration {

// The rig's nominal directions in the sample frame, towards the turntable
// centre: views = turntable angles x cameras, lights = (arc - turntable)
// angles x lamps (distinct directions only). Named "<rig>-views" / "<rig>-lights".
core::SamplingSet ViewDirections(const formats::RigDescription& rig);
core::SamplingSet LightDirections(const formats::RigDescription& rig);

// World positions of devices (the nominal geometry above).
Eigen::Vector3d CameraCentre(const formats::CameraDescription& camera);
Eigen::Vector3d LampPosition(const formats::LampBankDescription& lamps, int lamp, double arc_angle_rad);
Eigen::Vector3d LaserSource(const formats::LaserDescription& laser, const formats::LaserLocation& location);
// The laser's tilt axis at a location: the arc's tangent there (y rotated by
// the arc angle), along which the stripe runs on the turntable plane.
Eigen::Vector3d LaserTiltAxis(const formats::LaserLocation& location);
// The unit normal of the location's laser plane at tilt 0, which holds the
// tilt axis and passes through the source and the turntable centre.
Eigen::Vector3d LaserPlaneNormalAtZeroTilt(const formats::LaserDescription& laser,
                                           const formats::LaserLocation& location);
// Tilt 0 aims the laser plane at the origin; a positive tilt moves the stripe
// on the turntable plane away from the laser by `offset_mm`.
double LaserTiltForOffset(const formats::LaserDescription& laser, int mount, double offset_mm);

// The rig description's nominal geometry written as a calibration: cameras
// looking at the origin with OpenCV's camera frame (+z forward, +x right, +y
// down in the image), the turntable's axis along z through the origin, the
// lamps and laser mounts where the description puts them (a mount's tilt
// axis horizontal and tangent to the arc, oriented so that a positive tilt
// moves the stripe away from the laser). No radiometry, no uncertainty: the
// simulated rig's truth (sim/true_calibration.h) and the parts of a rig that
// a calibration did not measure.
formats::Calibration NominalCalibration(const formats::RigDescription& rig);

// How well a camera and a laser location triangulate (MDF paper Sec. 3.2):
// the sine of the angle between the camera's ray to the turntable centre and
// the location's laser plane at tilt 0 (through the centre, its stripe across
// the source's azimuth). A timing error becomes a depth error growing as
// 1 / sine; at 0 the plane contains the ray. For a camera at elevation c and
// a source at elevation e, arc a from the camera's azimuth, it is
// |sin c cos e - cos c sin e cos a|: zero where a mount shares a camera's
// elevation at its azimuth.
double LaserRaySine(const formats::RigDescription& rig, int camera, int location);

}  // namespace mesocap::calibration
