// The light arc's axis and the lamps' positions from their highlights on a
// mirror sphere of known radius at the sample centre (the rig description's
// mirror_sphere), imaged by every camera under each lamp alone at each arc
// angle.
//
// Each highlight's pixels are back-projected through their calibrated camera,
// met with the sphere (centre from the calibrated turntable and the sphere's
// cup), and reflected about the sphere's normal there. A lamp of uniform
// radiance fills a disc of directions about its centre's direction, so the
// mean of the reflected directions, each pixel weighted by its signal times
// the solid angle its reflected rays span, points at the lamp's centre: the
// lamp lies on that mean reflected ray. (The pixels' centroid does not: the
// mirror magnifies one side of an extended lamp's image more than the other,
// a bias of a few hundredths of a pixel that the lamps' distances, observed
// over the sphere's short baseline, turn into millimetres.) The lamp's position in the light_arc frame p_l and the
// arc's axis (point q, unit direction a) are then fitted in one Ceres
// problem to every reflected ray: a lamp at arc angle t is at
// q + R(a, t) (p_l - q) in the world, and each ray contributes its two
// perpendicular distances (mm) to that point. Standard deviations come from
// the Ceres covariance at the solution, scaled by the residuals' variance.
//
// Conditioning:
// - A ray's error at the lamp is about 2 D dx / R for a highlight error dx
//   (mm on the sphere), lamp distance D and sphere radius R: the reflection
//   doubles the normal's error. Near the sphere's outline a pixel spans a
//   long arc of the surface, so highlights seen more obliquely than
//   max_incidence_deg are left out (and reported).
// - One camera and one arc angle give a lamp one ray: its distance along it
//   is unobservable. Two cameras close together, or arc angles close
//   together, triangulate at a narrow angle: a large sigma, not a wrong
//   confident value. A lamp with fewer than two rays is an error naming it.
// - The axis needs a lamp seen at two arc angles or more off the axis; with
//   one arc angle only, the axis is the nominal one, not estimated (said in
//   the result), and lamp positions are relative to it.
// - The sphere's centre (its cup's place in the sample frame) is fitted
//   too: an error e in it turns each ray by about 2 e / R, which the lamps
//   at distance D would take as 2 D e / R (about 0.1 mm of e per mm of lamp
//   on the shipped rigs). Its rays are first order in the cup's move,
//   relinearized once.
// - The cameras' calibration errors enter the rays as they are: the ray
//   residual with estimated cameras is several times that with exact ones,
//   and the sigmas, scaled by it, say so.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calibration/sphere_highlight.h"
#include "core/error.h"
#include "formats/calibration.h"

namespace mesocap::calibration {

struct HighlightObservation {
  int camera = 0;              // index into the calibration's cameras
  int lamp = 0;                // index into the calibration's lamps
  double turntable_rad = 0.0;  // the sphere's cup turns with the turntable
  double arc_rad = 0.0;
  std::vector<HighlightPixel> pixels;  // calibration/sphere_highlight.h
  std::string name;                    // for messages: the image it came from
};

struct LightArcOptions {
  double sphere_radius_mm = 0.0;
  // The sphere's centre in the sample frame: offset along x from the
  // turntable's axis, height above the reference plane.
  double sphere_offset_mm = 0.0;
  double sphere_centre_height_mm = 0.0;
  double max_incidence_deg = 75.0;  // of the camera's ray on the sphere, from its normal
  // Above these one-sigma uncertainties (any lamp's position or the axis
  // point along any axis, mm; the axis direction, degrees) the fit is too
  // uncertain to replace the rig description's nominal geometry
  // (LightArcResult::too_uncertain).
  double max_lamp_sigma_mm = 5.0;
  double max_axis_sigma_deg = 0.1;
  core::CheckResult Check() const;
};

struct LeftOutHighlight {
  std::string name;
  std::string reason;
};

struct LightArcResult {
  formats::LightArcCalibration light_arc;  // with its uncertainty where estimated
  bool axis_estimated = false;
  // Per calibration lamp: position in the light_arc frame with its sigma.
  std::vector<std::string> lamp_ids;
  std::vector<Eigen::Vector3d> lamp_position, lamp_position_sigma;
  int highlights_used = 0;
  std::vector<LeftOutHighlight> left_out;
  // The angles between the rays and the directions to their lamps, RMS,
  // times the lamps' nominal distances: mm across a ray at its lamp.
  double ray_residual_rms_mm = 0.0;
  // The sphere's centre in the sample frame (its cup's place), fitted with
  // the lamps, with its sigma.
  Eigen::Vector3d sphere_centre_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d sphere_centre_sigma_mm = Eigen::Vector3d::Zero();
  std::vector<std::string> warnings;
  // Why the result should not replace the nominal light arc and lamps (a
  // sigma beyond the options' limits, or none at all); empty when it may.
  std::string too_uncertain;
};

// `geometry` gives the calibrated cameras and turntable, and the nominal
// light arc and lamps the fit starts from. Throws Error naming the lamp
// when one has fewer than two usable rays.
LightArcResult CalibrateLightArc(const formats::Calibration& geometry, const std::vector<HighlightObservation>& seen,
                                 const LightArcOptions& options);

}  // namespace mesocap::calibration
