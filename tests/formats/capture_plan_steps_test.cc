// The typed plan steps are read strictly against the session's rig: no
// unknown members, every number in its range, one tilt and offset per frame.
#include "formats/capture_plan_steps.h"

#include <gtest/gtest.h>

#include <string>
#include <variant>

#include "core/error.h"
#include "formats/rig_description.h"
#include "tests/common/error_of.h"

namespace mesocap::formats {
namespace {

using testing::ErrorOf;

RigDescription TinyRig() { return ReadRigDescription(std::string(MESOCAP_SOURCE_DIR) + "/sim/rigs/tiny.json"); }

PlannedStep Sweep(const RigDescription& rig) {
  LaserSweepStep step;
  step.mount = rig.laser.locations[0].mount;
  for (int f = 0; f < rig.laser.frames_per_sweep; ++f) {
    step.offsets_mm.push_back(-1.0 + f * 0.01);
    step.tilts_rad.push_back(0.001 * f);
  }
  for (const CameraDescription& c : rig.cameras) step.files.push_back({c.id, "laser/t0_loc0_" + c.id + ".tif"});
  return ToPlannedStep("laser-sweep-t0_loc0", step);
}

std::string SweepError(const PlannedStep& step, const RigDescription& rig) {
  return ErrorOf<core::FormatError>([&] { ReadLaserSweepStep(step, 3, rig, "manifest.json"); });
}

TEST(CapturePlanSteps, ASweepStepReadsBackAsWritten) {
  const RigDescription rig = TinyRig();
  const LaserSweepStep read = ReadLaserSweepStep(Sweep(rig), 3, rig, "manifest.json");
  ASSERT_EQ(read.tilts_rad.size(), static_cast<std::size_t>(rig.laser.frames_per_sweep));
  EXPECT_DOUBLE_EQ(read.offsets_mm[2], -0.98);
  EXPECT_EQ(read.files.size(), rig.cameras.size());
}

TEST(CapturePlanSteps, NumbersOutsideTheirRangeAreRefusedWithTheRange) {
  const RigDescription rig = TinyRig();
  PlannedStep step = Sweep(rig);
  step.params["tilt_deg"][5] = 1e300;
  EXPECT_EQ(SweepError(step, rig),
            "manifest.json: field 'plan[3].tilt_deg[5]': expected a finite number in [-90, 90], got number 1e+300");
  step = Sweep(rig);
  step.params["offset_mm"][0] = -1e9;
  EXPECT_NE(SweepError(step, rig).find("field 'plan[3].offset_mm[0]': expected a finite number in [-100000, 100000]"),
            std::string::npos)
      << SweepError(step, rig);
  step = Sweep(rig);
  step.params["mount"] = 7;
  EXPECT_NE(SweepError(step, rig).find("field 'plan[3].mount': expected an integer in [0, "), std::string::npos)
      << SweepError(step, rig);
  step = Sweep(rig);
  step.params["turntable_index"] = static_cast<int>(rig.turntable.angles_rad.size());
  EXPECT_NE(SweepError(step, rig).find("field 'plan[3].turntable_index'"), std::string::npos) << SweepError(step, rig);
}

// 3 or 200000 offsets for a sweep of the rig's frames_per_sweep frames.
TEST(CapturePlanSteps, ListsMustHaveOneEntryPerFrameAndCamera) {
  const RigDescription rig = TinyRig();
  const std::string frames = std::to_string(rig.laser.frames_per_sweep);
  for (const std::size_t count : {std::size_t{3}, std::size_t{200000}}) {
    PlannedStep step = Sweep(rig);
    step.params["offset_mm"] = nlohmann::json(std::vector<double>(count, 0.5));
    EXPECT_EQ(SweepError(step, rig),
              "manifest.json: field 'plan[3].offset_mm': expected one number per frame of the "
              "rig's sweep (laser.frames_per_sweep = " +
                  frames + "), got " + std::to_string(count) + " entries");
  }
  PlannedStep step = Sweep(rig);
  step.params["tilt_deg"].erase(0);
  EXPECT_NE(SweepError(step, rig).find("field 'plan[3].tilt_deg': expected one number per frame"), std::string::npos);
  step = Sweep(rig);
  step.params["files"].erase(0);
  EXPECT_NE(SweepError(step, rig).find("field 'plan[3].files': expected one file per camera of the rig"),
            std::string::npos)
      << SweepError(step, rig);
}

TEST(CapturePlanSteps, UnknownMembersAreErrors) {
  const RigDescription rig = TinyRig();
  PlannedStep step = Sweep(rig);
  step.params["tilt_degs"] = 1;
  EXPECT_NE(SweepError(step, rig).find("field 'plan[3].tilt_degs': unknown member"), std::string::npos)
      << SweepError(step, rig);
  step = Sweep(rig);
  step.params["files"][0]["bytes"] = 1;
  EXPECT_NE(SweepError(step, rig).find("field 'plan[3].files[0].bytes': unknown member"), std::string::npos)
      << SweepError(step, rig);
}

// A white reference step names a lamp of the rig, and needs the rig's
// white_reference.
TEST(CapturePlanSteps, AWhiteReferenceStepIsReadStrictly) {
  RigDescription rig = TinyRig();
  WhiteReferenceStep white;
  white.lamp = 1;
  white.arc_rad = 0.5;
  for (const CameraDescription& c : rig.cameras) white.files.push_back({c.id, "white/l1_" + c.id + ".png"});
  const PlannedStep step = ToPlannedStep("white-l1", white);
  const WhiteReferenceStep read = ReadWhiteReferenceStep(step, 2, rig, "manifest.json");
  EXPECT_EQ(read.lamp, 1);
  EXPECT_NEAR(read.arc_rad, 0.5, 1e-9);
  EXPECT_EQ(read.files.size(), rig.cameras.size());
  auto error = [&](const PlannedStep& s, const RigDescription& r) {
    return ErrorOf<core::FormatError>([&] { ReadWhiteReferenceStep(s, 2, r, "manifest.json"); });
  };
  PlannedStep bad = step;
  bad.params["lamp"] = static_cast<int>(rig.lamps.elevations_rad.size());
  EXPECT_NE(error(bad, rig).find("field 'plan[2].lamp': expected an integer in [0, "), std::string::npos)
      << error(bad, rig);
  bad = step;
  bad.params["albedo"] = 0.8;
  EXPECT_NE(error(bad, rig).find("field 'plan[2].albedo': unknown member"), std::string::npos) << error(bad, rig);
  rig.white_reference.reset();
  EXPECT_NE(error(step, rig).find("needs the rig's white_reference"), std::string::npos) << error(step, rig);
}

// A mirror sphere step names a turntable angle and an arc angle of the
// rig's mirror_sphere and a lamp, and needs the rig's mirror_sphere.
TEST(CapturePlanSteps, AMirrorSphereStepIsReadStrictly) {
  RigDescription rig = TinyRig();
  ASSERT_TRUE(rig.mirror_sphere.has_value());
  MirrorSphereStep sphere;
  sphere.turntable_index = static_cast<int>(rig.mirror_sphere->turntable_angles_rad.size()) - 1;
  sphere.turntable_rad = rig.mirror_sphere->turntable_angles_rad.back();
  sphere.arc_index = 1;
  sphere.arc_rad = rig.mirror_sphere->arc_angles_rad.at(1);
  sphere.lamp = 1;
  for (const CameraDescription& c : rig.cameras) sphere.files.push_back({c.id, "sphere/t0_a1_l1_" + c.id + ".png"});
  const PlannedStep step = ToPlannedStep("sphere-t0_a1_l1", sphere);
  EXPECT_EQ(step.kind, StepKind::kMirrorSphere);
  const MirrorSphereStep read = ReadMirrorSphereStep(step, 4, rig, "manifest.json");
  EXPECT_EQ(read.turntable_index, sphere.turntable_index);
  EXPECT_NEAR(read.turntable_rad, sphere.turntable_rad, 1e-9);
  EXPECT_EQ(read.arc_index, 1);
  EXPECT_NEAR(read.arc_rad, sphere.arc_rad, 1e-9);
  EXPECT_EQ(read.lamp, 1);
  EXPECT_EQ(read.files.size(), rig.cameras.size());
  EXPECT_TRUE(std::holds_alternative<MirrorSphereStep>(ReadCaptureStep(step, 4, rig, "manifest.json")));
  auto error = [&](const PlannedStep& s, const RigDescription& r) {
    return ErrorOf<core::FormatError>([&] { ReadMirrorSphereStep(s, 4, r, "manifest.json"); });
  };
  PlannedStep bad = step;
  bad.params["arc_index"] = static_cast<int>(rig.mirror_sphere->arc_angles_rad.size());
  EXPECT_NE(error(bad, rig).find("field 'plan[4].arc_index': expected an integer in [0, "), std::string::npos)
      << error(bad, rig);
  bad = step;
  bad.params["turntable_index"] = static_cast<int>(rig.mirror_sphere->turntable_angles_rad.size());
  EXPECT_NE(error(bad, rig).find("field 'plan[4].turntable_index'"), std::string::npos) << error(bad, rig);
  bad = step;
  bad.params["radius_mm"] = 8;
  EXPECT_NE(error(bad, rig).find("field 'plan[4].radius_mm': unknown member"), std::string::npos) << error(bad, rig);
  rig.mirror_sphere.reset();
  EXPECT_NE(error(step, rig).find("needs the rig's mirror_sphere"), std::string::npos) << error(step, rig);
}

}  // namespace
}  // namespace mesocap::formats
