#include "acquisition/capture_session_runner.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <map>

#include "acquisition/capture_plan.h"
#include "core/angles.h"
#include "core/image_io.h"
#include "formats/capture_journal.h"
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/captured_session.h"
#include "formats/frame_sequence.h"
#include "mdf/mdf_session.h"
#include "sim/camera_renderer.h"
#include "sim/fault_plan.h"
#include "sim/mesostructure_scene.h"
#include "sim/shipped_rigs.h"
#include "sim/simulated_operator.h"
#include "sim/simulated_rig_backend.h"
#include "sim/true_calibration.h"
#include "tests/common/temporary_directory.h"

namespace mesocap::acquisition {
namespace {

namespace fs = std::filesystem;

// The tiny rig cut to one turntable angle, one arc angle and one laser
// location with 8 frames: 2 calibration steps, 2 BTF image steps (one per
// lamp), 1 sweep, each for both 128 x 96 cameras. The file snapshot a
// session keeps says the same, as the plan's strict reader requires.
formats::RigDescription SmallPlanRig(int frames_per_sweep = 8, bool stores_analysis = false) {
  formats::RigDescription rig = sim::LoadRig("tiny");
  rig.turntable.angles_rad = {0.6};
  rig.light_arc.angles_rad = {2.0};
  rig.laser.locations.resize(1);
  rig.laser.frames_per_sweep = frames_per_sweep;
  rig.json["turntable"]["angles_deg"] = {core::DegreesFromRadians(0.6)};
  rig.json["light_arc"]["angles_deg"] = {core::DegreesFromRadians(2.0)};
  rig.json["laser"]["locations"] = nlohmann::json::array({rig.json["laser"]["locations"][0]});
  rig.json["laser"]["frames_per_sweep"] = frames_per_sweep;
  if (stores_analysis) {
    rig.laser.sweep_storage = formats::LaserDescription::SweepStorage::kAnalysis;
    rig.json["laser"]["sweep_storage"] = "analysis";
  }
  return rig;
}

sim::FaultRule Rule(sim::FaultKind kind, std::optional<double> rate, std::vector<std::uint64_t> at = {},
                    std::string device = "") {
  sim::FaultRule r;
  r.kind = kind;
  r.rate = rate;
  r.at = std::move(at);
  r.device = std::move(device);
  return r;
}

// The simulated operator, counting what the capture asked of the person.
class CountingOperator : public drivers::RigOperator {
 public:
  explicit CountingOperator(std::shared_ptr<sim::SimulatedRigState> state) : hands_(std::move(state)) {}
  void PlaceCalibrationPlate(double height_mm) override {
    ++calls_["place plate"];
    hands_.PlaceCalibrationPlate(height_mm);
  }
  void RemoveCalibrationPlate() override {
    ++calls_["remove plate"];
    hands_.RemoveCalibrationPlate();
  }
  void MountLaser(int mount) override {
    ++calls_["mount laser"];
    hands_.MountLaser(mount);
  }
  void PlaceCalibrationBoard(int holder, double tilt_rad) override {
    ++calls_["place board"];
    hands_.PlaceCalibrationBoard(holder, tilt_rad);
  }
  void RemoveCalibrationBoard() override {
    ++calls_["remove board"];
    hands_.RemoveCalibrationBoard();
  }
  void PlaceWhiteReference(double height_mm) override {
    ++calls_["place white"];
    hands_.PlaceWhiteReference(height_mm);
  }
  void RemoveWhiteReference() override {
    ++calls_["remove white"];
    hands_.RemoveWhiteReference();
  }
  void PlaceMirrorSphere() override {
    ++calls_["place sphere"];
    hands_.PlaceMirrorSphere();
  }
  void RemoveMirrorSphere() override {
    ++calls_["remove sphere"];
    hands_.RemoveMirrorSphere();
  }
  const std::map<std::string, int>& calls() const { return calls_; }

 private:
  sim::SimulatedOperator hands_;
  std::map<std::string, int> calls_;
};

// One simulated capture of `weave` into `dir`, with the given faults.
class SimulatedCapture {
 public:
  SimulatedCapture(const formats::RigDescription& rig, sim::FaultPlan faults)
      : scene_(sim::MakeBuiltinScene("weave")),
        rig_description_(rig),
        renderer_(*scene_, rig_description_, {1}),
        backend_(renderer_, std::move(faults), 5, sim::SensorModel::kNoisy),
        rig_(drivers::BuildRig(rig_description_, {{"sim", &backend_}})),
        operator_(backend_.shared_state()) {}

  CaptureRunReport Run(const fs::path& dir, const formats::Calibration* calibration = nullptr,
                       std::function<bool()> stop_before_step = {}, const CaptureStepDone& step_done = {}) {
    CaptureRunnerOptions options;
    options.show_progress = false;
    options.calibration = calibration;
    options.stop_before_step = std::move(stop_before_step);
    return RunCaptureSession(dir, rig_, operator_, options, step_done);
  }
  CaptureRunReport Run(const fs::path& dir, CaptureRunnerOptions options) {
    options.show_progress = false;
    return RunCaptureSession(dir, rig_, operator_, options);
  }

  const sim::SimulatedRigState& state() const { return backend_.state(); }
  // What the capture asked of the operator, by kind.
  const std::map<std::string, int>& operator_calls() const { return operator_.calls(); }

 private:
  std::unique_ptr<sim::MesostructureScene> scene_;
  formats::RigDescription rig_description_;
  sim::CameraRenderer renderer_;
  sim::SimulatedRigBackend backend_;
  drivers::Rig rig_;
  CountingOperator operator_;
};

void CreateSession(const fs::path& dir, const formats::RigDescription& rig) {
  formats::SessionManifest manifest;
  manifest.rig = rig.json;
  manifest.plan = MakeCapturePlan(rig, {{"simulated_scene", "weave"}});
  formats::CreateCaptureSession(dir, manifest);
}

// Every file of the session, decoded, by path.
std::map<std::string, std::vector<float>> SessionPixels(const fs::path& dir) {
  std::map<std::string, std::vector<float>> out;
  const formats::SessionManifest manifest = formats::ReadSessionManifest(dir);
  const formats::RigDescription rig = formats::ParseRigDescription(manifest.rig, dir / formats::kSessionManifestName);
  for (std::size_t s = 0; s < manifest.plan.size(); ++s) {
    const formats::PlannedStep& step = manifest.plan[s];
    const formats::CaptureStep typed = formats::ReadCaptureStep(step, s, rig, dir / formats::kSessionManifestName);
    for (const formats::CameraFile& f : formats::Files(typed)) {
      const std::string& path = f.path;
      std::vector<float>& values = out[path];
      if (step.kind == formats::StepKind::kLaserSweep) {
        formats::FrameSequenceReader reader(dir / path);
        core::Image frame;
        while (reader.Next(&frame)) values.insert(values.end(), frame.data(), frame.data() + frame.size());
      } else {
        const core::Image image = core::ReadImage(dir / path);
        values.assign(image.data(), image.data() + image.size());
      }
    }
  }
  return out;
}

std::size_t JournaledSteps(const fs::path& dir) {
  const formats::SessionManifest manifest = formats::ReadSessionManifest(dir);
  return formats::ReadCaptureJournal(dir / formats::kSessionJournalName, &manifest).records.size();
}

TEST(CaptureSessionRunner, RecordsEveryStepOfThePlan) {
  testing::TemporaryDirectory dir;
  const auto rig = SmallPlanRig();
  CreateSession(dir / "s", rig);
  SimulatedCapture capture(rig, {});
  const CaptureRunReport report = capture.Run(dir / "s");
  EXPECT_EQ(report.steps_done_before, 0u);
  EXPECT_EQ(report.steps_run, 5u);
  EXPECT_EQ(report.frames, 2u * (2 + 2 + 8));
  EXPECT_EQ(report.dropped_frames, 0u);
  EXPECT_EQ(report.retries, 0u);
  EXPECT_EQ(JournaledSteps(dir / "s"), 5u);
  // The rig is left dark, the plate removed.
  EXPECT_FALSE(capture.state().laser_on);
  EXPECT_FALSE(capture.state().calibration_plate_height_mm.has_value());
  for (bool on : capture.state().lamps_on) EXPECT_FALSE(on);

  const auto pixels = SessionPixels(dir / "s");
  // The stripe on the two calibration plates: the 10 mm plate is closer to
  // the laser, so the stripe lies elsewhere in the image than on the 0 mm
  // one (Sec. 3.2 derives the plane's angle from that offset).
  const auto& low = pixels.at("laser_calibration/loc0_h0_cam0.png");
  const auto& high = pixels.at("laser_calibration/loc0_h1_cam0.png");
  ASSERT_EQ(low.size(), 128u * 96u);
  const auto peak = [](const std::vector<float>& v) { return std::max_element(v.begin(), v.end()) - v.begin(); };
  EXPECT_GT(low[peak(low)], 0.2f);
  EXPECT_GT(high[peak(high)], 0.2f);
  EXPECT_NE(peak(low) % 128, peak(high) % 128);
  // A sweep of 8 frames, 128 x 96 grey each.
  EXPECT_EQ(pixels.at("laser/t0_loc0_cam1.tif").size(), 8u * 128u * 96u);
}

// The operator lays each calibration plate once, whatever the number of
// laser locations: the plan orders the plates by height, and the plate stays
// on between the steps that image it. The laser unit moves to mount 1 and
// back for the plates (the second height's locations in reverse), then once
// more for the sweeps, which go one mount after the other.
TEST(CaptureSessionRunner, EachCalibrationPlateIsLaidOnceAndEachMountVisitedOnce) {
  testing::TemporaryDirectory dir;
  formats::RigDescription rig = SmallPlanRig(4);
  const formats::RigDescription tiny = sim::LoadRig("tiny");
  rig.laser.locations = tiny.laser.locations;
  rig.json["laser"]["locations"] = tiny.json["laser"]["locations"];
  ASSERT_EQ(rig.laser.locations.size(), 3u);
  rig.turntable.angles_rad = {0.6, 2.1};
  rig.json["turntable"]["angles_deg"] = {core::DegreesFromRadians(0.6), core::DegreesFromRadians(2.1)};
  CreateSession(dir / "s", rig);
  SimulatedCapture capture(rig, {});
  const CaptureRunReport report = capture.Run(dir / "s");
  EXPECT_EQ(report.steps_run, 6u + 2u * 2u + 2u * 3u);
  const std::map<std::string, int> expected{{"place plate", 2}, {"remove plate", 2}, {"mount laser", 3}};
  EXPECT_EQ(capture.operator_calls(), expected);
  EXPECT_FALSE(capture.state().calibration_plate_height_mm.has_value());
}

// A mirror sphere step images at the sphere's exposure; the next step at
// each camera's own, whatever the last step left.
TEST(CaptureSessionRunner, TheMirrorSphereHasItsOwnExposure) {
  testing::TemporaryDirectory dir;
  formats::RigDescription rig = SmallPlanRig();
  ASSERT_TRUE(rig.mirror_sphere.has_value());
  formats::SessionManifest manifest;
  manifest.rig = rig.json;
  for (formats::PlannedStep& step : MakeCalibrationPlan(rig)) {
    const bool first_turn = !step.params.contains("turntable_index") || step.params["turntable_index"] == 0;
    if (step.kind == formats::StepKind::kMirrorSphere && first_turn && step.params["arc_index"] == 0) {
      manifest.plan.push_back(step);
    }
    if (step.kind == formats::StepKind::kWhiteReference) manifest.plan.push_back(step);
  }
  ASSERT_EQ(manifest.plan.size(), 2 * rig.lamps.elevations_rad.size());
  formats::CreateCaptureSession(dir / "s", manifest);
  SimulatedCapture capture(rig, {});
  std::vector<double> exposures;
  CaptureRunnerOptions options;
  options.frame_arrived = [&](const std::string&, const drivers::Frame& frame) {
    exposures.push_back(frame.settings.exposure_us);
  };
  capture.Run(dir / "s", options);
  const std::size_t sphere_frames = rig.lamps.elevations_rad.size() * rig.cameras.size();
  ASSERT_EQ(exposures.size(), 2 * sphere_frames);
  for (std::size_t i = 0; i < exposures.size(); ++i) {
    EXPECT_EQ(exposures[i], i < sphere_frames ? rig.mirror_sphere->exposure_us : rig.cameras[0].exposure_us) << i;
  }
  EXPECT_FALSE(capture.state().mirror_sphere_placed);
  // The lamp's highlight is in the sphere's image, well exposed.
  const core::Image sphere = core::ReadImage(dir / "s" / "sphere/t0_a0_l0_cam0.png");
  EXPECT_GT(*std::max_element(sphere.data(), sphere.data() + sphere.size()), 0.2f);
  EXPECT_LT(*std::max_element(sphere.data(), sphere.data() + sphere.size()), 1.0f);
}

// Faults that retries cure leave the data unchanged: each frame's noise is
// seeded by what it images, and a lost frame draws nothing.
TEST(CaptureSessionRunner, CurableFaultsDoNotChangeTheData) {
  testing::TemporaryDirectory dir;
  const auto rig = SmallPlanRig();
  CreateSession(dir / "clean", rig);
  CreateSession(dir / "faulty", rig);
  SimulatedCapture clean(rig, {});
  clean.Run(dir / "clean");
  sim::FaultPlan faults{{Rule(sim::FaultKind::kCameraDropFrame, 0.2), Rule(sim::FaultKind::kCameraTimeout, 0.1),
                         Rule(sim::FaultKind::kStageTimeout, std::nullopt, {2}, "turntable"),
                         Rule(sim::FaultKind::kStageStall, std::nullopt, {3}, "light_arc")}};
  SimulatedCapture faulty(rig, faults);
  const CaptureRunReport report = faulty.Run(dir / "faulty");
  EXPECT_EQ(report.steps_run, 5u);
  EXPECT_GT(report.dropped_frames, 0u);
  EXPECT_GE(report.retries, 3u);  // at least a grab, the turntable's wait and the arc's stall
  EXPECT_GT(faulty.state().clock_s, clean.state().clock_s);
  EXPECT_EQ(SessionPixels(dir / "clean"), SessionPixels(dir / "faulty"));
}

// A rig whose sweeps are stored as analyses (the paper rig's
// "sweep_storage": "analysis") streams every frame through the same line
// detection and space-time analysis `process mdf` runs on stored frames,
// with the planes of the session's own calibration plates: the two sessions
// process to the same MDF, but for the stored frames' 16-bit rounding of the
// grey mean of three 12-bit channels (1/65535 of full scale, which moves a
// peak time by a little): within 0.005 mm, 1.3 % of the 0.375 mm texel
// (measured 0.0012 mm), and the same texels measured. Without the calibration the runner refuses such
// a plan before anything moves.
TEST(CaptureSessionRunner, SweepsStoredAsAnalysesProcessToTheSameMdf) {
  testing::TemporaryDirectory dir;
  const formats::RigDescription frames_rig = SmallPlanRig(48);
  const formats::RigDescription analysis_rig = SmallPlanRig(48, true);
  const formats::Calibration calibration = sim::TrueCalibration(frames_rig);
  CreateSession(dir / "frames", frames_rig);
  CreateSession(dir / "analysis", analysis_rig);
  SimulatedCapture(frames_rig, {}).Run(dir / "frames");

  EXPECT_THROW(SimulatedCapture(analysis_rig, {}).Run(dir / "analysis"), core::Error);
  EXPECT_EQ(JournaledSteps(dir / "analysis"), 0u);
  const CaptureRunReport report = SimulatedCapture(analysis_rig, {}).Run(dir / "analysis", &calibration);
  EXPECT_EQ(report.steps_run, 5u);
  EXPECT_TRUE(fs::exists(dir / "analysis" / "laser" / "t0_loc0_cam1.sweep.json"));
  EXPECT_TRUE(fs::exists(dir / "analysis" / "laser" / "t0_loc0_cam1.sweep.json.exr"));
  EXPECT_FALSE(fs::exists(dir / "analysis" / "laser" / "t0_loc0_cam1.tif"));

  auto compare = [&](const mdf::MdfProcessingOptions& options) {
    const mdf::MdfProcessingResult a = mdf::ProcessMdfSession(formats::CapturedSession(dir / "frames"), calibration,
                                                              options, core::Progress::Style::kSilent);
    const mdf::MdfProcessingResult b = mdf::ProcessMdfSession(formats::CapturedSession(dir / "analysis"), calibration,
                                                              options, core::Progress::Style::kSilent);
    EXPECT_EQ(a.mdf.distance_mm.size(), b.mdf.distance_mm.size());
    std::size_t measured = 0, disagree = 0;
    double worst = 0.0;
    for (std::size_t i = 0; i < a.mdf.distance_mm.size(); ++i) {
      const float x = a.mdf.distance_mm.data()[i], y = b.mdf.distance_mm.data()[i];
      if (std::isfinite(x) && std::isfinite(y)) {
        worst = std::max(worst, static_cast<double>(std::abs(x - y)));
        ++measured;
      } else if (!(x == y || (std::isnan(x) && std::isnan(y)))) {
        ++disagree;
      }
    }
    EXPECT_LT(worst, 0.005);
    EXPECT_EQ(disagree, 0u);
    return measured;
  };
  mdf::MdfProcessingOptions options;
  options.texture_size = 32;
  const std::size_t measured = compare(options);
  EXPECT_GT(measured, 200u);
  // A stricter threshold at processing time applies to the stored peaks too.
  options.space_time.threshold = 0.2f;
  EXPECT_LT(compare(options), measured);
}

// A camera that disconnects ends the run with an error naming the step and
// the camera; the journal keeps the finished steps, a later run (the camera
// back) resumes, removes what the interrupted write left, and the session
// equals one never interrupted.
TEST(CaptureSessionRunner, DisconnectStopsAndAResumeCompletes) {
  testing::TemporaryDirectory dir;
  const auto rig = SmallPlanRig();
  CreateSession(dir / "once", rig);
  SimulatedCapture({rig}, {}).Run(dir / "once");

  CreateSession(dir / "twice", rig);
  {
    // cam1's 20th call: inside the sweep (each frame costs a Trigger and a Grab).
    SimulatedCapture broken(rig, {{Rule(sim::FaultKind::kCameraDisconnect, std::nullopt, {20}, "cam1")}});
    try {
      broken.Run(dir / "twice");
      FAIL() << "no error";
    } catch (const core::Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("laser-sweep-t0_loc0"), std::string::npos) << what;
      EXPECT_NE(what.find("cam1"), std::string::npos) << what;
      EXPECT_NE(what.find("disconnected"), std::string::npos) << what;
    }
  }
  EXPECT_EQ(JournaledSteps(dir / "twice"), 4u);
  EXPECT_FALSE(fs::exists(dir / "twice" / "laser" / "t0_loc0_cam0.tif"));
  std::ofstream(dir / "twice" / "laser" / ".t0_loc0_cam0.tmp-4242-0.tif") << "what a killed writer leaves";

  SimulatedCapture repaired(rig, {});
  const CaptureRunReport report = repaired.Run(dir / "twice");
  EXPECT_EQ(report.steps_done_before, 4u);
  EXPECT_EQ(report.steps_run, 1u);
  EXPECT_EQ(report.stale_temporaries_removed, 1u);
  EXPECT_EQ(JournaledSteps(dir / "twice"), 5u);
  EXPECT_EQ(SessionPixels(dir / "once"), SessionPixels(dir / "twice"));
}

// A stop asked for between steps ends the run there with the rig dark and
// every finished step journaled; the next run completes the same data.
TEST(CaptureSessionRunner, StopBetweenStepsKeepsTheJournalAndResumes) {
  testing::TemporaryDirectory dir;
  const auto rig = SmallPlanRig();
  CreateSession(dir / "once", rig);
  SimulatedCapture({rig}, {}).Run(dir / "once");

  CreateSession(dir / "twice", rig);
  std::vector<std::size_t> journaled;
  {
    SimulatedCapture capture(rig, {});
    const CaptureRunReport report = capture.Run(
        dir / "twice", nullptr, [&] { return journaled.size() == 3; },
        [&](const CaptureRunReport& so_far, std::size_t steps) {
          EXPECT_EQ(so_far.steps_total, 5u);
          EXPECT_EQ(so_far.steps_run, steps);
          journaled.push_back(steps);
        });
    EXPECT_TRUE(report.stopped);
    EXPECT_EQ(report.steps_run, 3u);
    EXPECT_FALSE(capture.state().laser_on);
    for (bool on : capture.state().lamps_on) EXPECT_FALSE(on);
  }
  EXPECT_EQ(journaled, (std::vector<std::size_t>{1, 2, 3}));
  EXPECT_EQ(JournaledSteps(dir / "twice"), 3u);

  const CaptureRunReport rest = SimulatedCapture(rig, {}).Run(dir / "twice", nullptr, [] { return false; });
  EXPECT_FALSE(rest.stopped);
  EXPECT_EQ(rest.steps_done_before, 3u);
  EXPECT_EQ(rest.steps_run, 2u);
  EXPECT_EQ(SessionPixels(dir / "once"), SessionPixels(dir / "twice"));
}

TEST(CaptureSessionRunner, FaultsRetriesCannotCureNameTheDevice) {
  const auto rig = SmallPlanRig();
  struct Case {
    sim::FaultRule rule;
    const char* expected;
  };
  const Case cases[] = {
      {Rule(sim::FaultKind::kLampFailure, std::nullopt, {1}, "1"), "lamp 1"},
      {Rule(sim::FaultKind::kCameraTimeout, 1.0, {}, "cam0"), "gave up after 4 tries"},
      {Rule(sim::FaultKind::kStageStall, 1.0, {}, "light_arc"), "light_arc"},
  };
  for (const Case& c : cases) {
    testing::TemporaryDirectory dir;
    CreateSession(dir / "s", rig);
    SimulatedCapture capture(rig, {{c.rule}});
    try {
      capture.Run(dir / "s");
      ADD_FAILURE() << "no error for " << c.expected;
    } catch (const core::Error& e) {
      EXPECT_NE(std::string(e.what()).find(c.expected), std::string::npos) << e.what();
    }
  }
}

TEST(CaptureSessionRunner, RefusesPlansItCannotRun) {
  const auto rig = SmallPlanRig();
  {
    testing::TemporaryDirectory dir;
    formats::SessionManifest manifest;
    manifest.rig = rig.json;
    manifest.plan = MakeCapturePlan(rig);
    manifest.plan.push_back({"focus-by-hand", formats::StepKind::kOther, {{"files", nlohmann::json::array()}}});
    formats::CreateCaptureSession(dir / "s", manifest);
    SimulatedCapture capture(rig, {});
    EXPECT_THROW(capture.Run(dir / "s"), core::Error);
    EXPECT_EQ(JournaledSteps(dir / "s"), 0u);
  }
  {
    // A plan for a rig with a camera this rig lacks.
    testing::TemporaryDirectory dir;
    auto other = rig;
    other.cameras[1].id = "cam9";
    CreateSession(dir / "s", other);
    SimulatedCapture capture(rig, {});
    try {
      capture.Run(dir / "s");
      FAIL() << "no error";
    } catch (const core::Error& e) {
      EXPECT_NE(std::string(e.what()).find("\"cam9\""), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace mesocap::acquisition
