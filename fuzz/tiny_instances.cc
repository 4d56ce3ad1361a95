#include "fuzz/tiny_instances.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/btf.h"
#include "core/mdf.h"

namespace mesocap::fuzz {
namespace fs = std::filesystem;

namespace {
constexpr int kWidth = 4;
constexpr int kHeight = 3;

core::SamplingSet TinyViews() {
  return core::SamplingSet::FromAngles("tiny-views", {{0.0, 0.0}, {0.6, 0.0}, {0.6, 3.0}});
}
core::SamplingSet TinyLights() { return core::SamplingSet::FromAngles("tiny-lights", {{0.3, 1.0}, {0.9, 4.0}}); }

// A deterministic value in [0, 1) that differs between neighbours.
float Ramp(int i) { return static_cast<float>((i * 37) % 101) / 101.0f; }

void FillRamp(core::Image* image, float scale, float offset) {
  for (std::size_t i = 0; i < image->size(); ++i) image->data()[i] = offset + scale * Ramp(static_cast<int>(i));
}
}  // namespace

core::Image TinyImage(int width, int height, int channels) {
  core::Image image(width, height, channels);
  FillRamp(&image, 1.0f, 0.0f);
  return image;
}

formats::MaterialPackage TinyMaterialPackage() {
  formats::MaterialPackage package;
  package.description = {.name = "tiny",
                         .width = kWidth,
                         .height = kHeight,
                         .physical_size_mm = {4.0, 3.0},
                         .d_max_mm = 1.0,
                         .view_directions = TinyViews(),
                         .light_directions = TinyLights(),
                         .provenance = {.software_version = "", .created_utc = "", .source = "fuzz seed"}};

  core::Mdf mdf = core::MakeMdf(kWidth, kHeight, TinyViews());
  for (int v = 0; v < mdf.view_count(); ++v)
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) mdf.at(x, y, v) = 0.9f * Ramp(x + kWidth * (y + kHeight * v));
  mdf.at(0, 0, 1) = core::MdfNoHit();
  mdf.at(1, 2, 2) = core::MdfUnknown();
  package.mdf = std::move(mdf);

  core::FullBtf full = core::MakeFullBtf(kWidth, kHeight, TinyViews(), TinyLights());
  for (core::Image& view : full.view_images) FillRamp(&view, 1.0f, 0.0f);
  package.full_btf = std::move(full);

  core::FactoredBtf factored;
  factored.width = kWidth;
  factored.height = kHeight;
  factored.views = TinyViews();
  factored.lights = TinyLights();
  factored.color = core::BtfFactorColor::kYCbCr;
  factored.rgb_to_factored = core::YCbCrFromLinearRgbBt601();
  for (int k = 0; k < 2; ++k) {
    core::Image rows(kWidth, factored.row_image_height(), 3);
    FillRamp(&rows, 1.0f, -0.5f * k);
    factored.rows.push_back(std::move(rows));
  }
  factored.columns = core::Image(factored.column_count(), factored.rank(), 3);
  FillRamp(&factored.columns, 1.0f, 0.25f);
  package.factored_btf = std::move(factored);

  formats::AmbientTerm ambient;
  ambient.width = kWidth;
  ambient.height = kHeight;
  ambient.views = TinyViews();
  ambient.values = core::Image(kWidth, kHeight * ambient.view_count(), 3);
  FillRamp(&ambient.values, 2.0f, 0.0f);
  package.ambient = std::move(ambient);

  package.error_report = nlohmann::json{{"mdf_rms_error_mm", 0.01}};
  return package;
}

std::vector<fs::path> FilesOf(const fs::path& dir) {
  std::vector<fs::path> files;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) files.push_back(fs::relative(entry.path(), dir));
  }
  std::sort(files.begin(), files.end());
  return files;
}

formats::SessionManifest TinySessionManifest() {
  formats::SessionManifest m;
  m.software_version = "0.1.0";
  m.created_utc = "2025-06-01T12:00:00.000Z";
  m.rig = {{"name", "tiny"}};
  m.calibration = "calibration.json";
  m.calibration_checksum = core::FileChecksum{3668, 0x1d0cae9f0528d597};
  m.plan.push_back({"btf-t000-a000-l0", formats::StepKind::kBtfImage, nlohmann::json::object()});
  m.plan.push_back({"laser-cal-loc0-h0", formats::StepKind::kLaserCalibration, nlohmann::json::object()});
  m.plan.push_back({"sweep-t000-loc0", formats::StepKind::kLaserSweep, nlohmann::json::object()});
  m.plan.push_back({"dark-frame", formats::StepKind::kOther, nlohmann::json::object()});
  return m;
}

std::string TinyObjText() {
  return "# unit cube\n"
         "o cube\n"
         "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
         "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
         "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 1 0 0\nvn 0 1 0\nvn -1 0 0\n"
         "usemtl grey\ns off\n"
         "f 1/1/1 4/4/1 3/3/1 2/2/1\n"
         "f 5/1/2 6/2/2 7/3/2 8/4/2\n"
         "f 1//3 2//3 6//3 5//3\n"
         "f 2/1 3/2 7/3 6/4\n"
         "f -5 -6 -2 -1\n"
         "f 1 5 8 4\n";
}

formats::SweepAnalysis TinySweepAnalysis() {
  formats::SweepAnalysis a;
  a.width = 5;
  a.height = 4;
  a.frame_count = 3;
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  const std::size_t pixels = static_cast<std::size_t>(a.width) * a.height;
  for (std::size_t i = 0; i < pixels; ++i) {
    const float t = 2.0f * Ramp(static_cast<int>(i));
    a.peak_time.push_back(i == 3 ? kNaN : t);
    a.peak_value.push_back(i == 3 ? 0.0f : 0.5f + 0.25f * t);  // a fraction of full scale
    a.second_time.push_back(i == 7 ? 1.5f : kNaN);
    a.second_value.push_back(i == 7 ? 0.3f : 0.0f);
  }
  for (int f = 0; f < a.frame_count; ++f) {
    core::Plane plane;
    if (f != 1) {
      plane.normal = Eigen::Vector3d(1.0, 0.0, 0.2 * f).normalized();
      plane.offset = 0.5 * f;
    }
    a.planes.push_back(plane);
  }
  return a;
}

}  // namespace mesocap::fuzz
