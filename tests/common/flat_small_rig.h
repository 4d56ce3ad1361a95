// The fixture of the laser-geometry tests: the `flat` scene on the `small`
// simulated rig with its true calibration, whose exact laser planes
// (sim::CameraRenderer::LaserPlaneAt) the calibration and MDF code are
// measured against.
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "formats/calibration.h"
#include "formats/rig_description.h"
#include "sim/camera_renderer.h"
#include "sim/mesostructure_scene.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"

namespace mesocap::testing {

class FlatSmallRigTest : public ::testing::Test {
 protected:
  FlatSmallRigTest()
      : scene_(sim::MakeBuiltinScene("flat")),
        rig_(sim::LoadRig("small")),
        calibration_(sim::TrueCalibration(rig_)),
        renderer_(*scene_, rig_) {}

  std::unique_ptr<sim::MesostructureScene> scene_;
  formats::RigDescription rig_;
  formats::Calibration calibration_;
  sim::CameraRenderer renderer_;
};

}  // namespace mesocap::testing
