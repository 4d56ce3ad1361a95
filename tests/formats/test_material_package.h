// A small material package with every part (5 x 4 texels, two views, two
// lights), and the file helpers the material format's tests share
// (material_package_test.cc, hostile_material_package_test.cc).
#pragma once

#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/error.h"
#include "core/image.h"
#include "core/image_io.h"
#include "formats/material_package.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"

namespace mesocap::formats::test_package {
namespace fs = std::filesystem;

inline constexpr int kW = 5;
inline constexpr int kH = 4;

inline core::SamplingSet TestViews() {
  return core::SamplingSet::FromAngles("test-views", {{0.0, 0.0}, {0.5, 0.0}, {0.5, 2.0}});
}
inline core::SamplingSet TestLights() {
  return core::SamplingSet::FromAngles("test-lights", {{0.2, 1.0}, {0.7, 0.0}, {0.7, 2.0}, {0.7, 4.0}});
}

inline MaterialDescription TestDescription() {
  MaterialDescription d;
  d.name = "weave";
  d.width = kW;
  d.height = kH;
  d.physical_size_mm = {10.0, 8.0};
  d.d_max_mm = 1.5;
  d.view_directions = TestViews();
  d.light_directions = TestLights();
  d.provenance.source = "groundtruth scene=weave rig=small";
  d.provenance.texel_samples_per_side = 4;
  return d;
}

inline core::Mdf TestMdf() {
  core::Mdf mdf = core::MakeMdf(kW, kH, TestViews());
  for (int v = 0; v < mdf.view_count(); ++v)
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) mdf.at(x, y, v) = 0.0137f * (x + 2 * y + 3 * v) + 0.001f * x * y;
  mdf.at(0, 0, 1) = core::MdfNoHit();
  mdf.at(4, 3, 2) = core::MdfNoHit();
  mdf.at(2, 1, 0) = core::MdfUnknown();
  mdf.at(3, 3, 2) = 0.0f;
  return mdf;
}

// Dyadic values: exact in float, in EXR and in sums of a few products.
inline float Dyadic(int a, int b, int c, int d) { return static_cast<float>((a + 3 * b + 5 * c + 7 * d) % 64) / 64.0f; }

inline core::FullBtf TestFullBtf() {
  core::FullBtf btf = core::MakeFullBtf(kW, kH, TestViews(), TestLights());
  for (int v = 0; v < btf.view_count(); ++v)
    for (int l = 0; l < btf.light_count(); ++l)
      for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x)
          for (int c = 0; c < 3; ++c) btf.view_images[v].at(x, l * kH + y, c) = Dyadic(x + c, y, v, l);
  return btf;
}

// A factored BTF with arbitrary (dyadic) factors.
inline core::FactoredBtf TestFactoredBtf(core::BtfFactorLayout layout, core::BtfFactorColor color, int rank) {
  core::FactoredBtf btf;
  btf.width = kW;
  btf.height = kH;
  btf.views = TestViews();
  btf.lights = TestLights();
  btf.layout = layout;
  btf.color = color;
  if (color == core::BtfFactorColor::kYCbCr) btf.rgb_to_factored = core::YCbCrFromLinearRgbBt601();
  for (int k = 0; k < rank; ++k) {
    core::Image rows(kW, btf.row_image_height(), 3);
    for (int y = 0; y < rows.height(); ++y)
      for (int x = 0; x < kW; ++x)
        for (int c = 0; c < 3; ++c) rows.at(x, y, c) = Dyadic(x, y, c, k) - 0.25f;
    btf.rows.push_back(rows);
  }
  btf.columns = core::Image(btf.column_count(), rank * btf.column_sets(), 3);
  for (int k = 0; k < btf.columns.height(); ++k)
    for (int i = 0; i < btf.column_count(); ++i)
      for (int c = 0; c < 3; ++c) btf.columns.at(i, k, c) = Dyadic(i, k, c, 1) + 0.5f;
  return btf;
}

inline AmbientTerm TestAmbient() {
  AmbientTerm a;
  a.width = kW;
  a.height = kH;
  a.views = TestViews();
  a.values = core::Image(kW, kH * 3, 3);
  for (int y = 0; y < kH * 3; ++y)
    for (int x = 0; x < kW; ++x)
      for (int c = 0; c < 3; ++c) a.values.at(x, y, c) = 0.1f * x + 0.01f * y + 0.3f * c;
  return a;
}

inline MaterialPackage FullTestPackage() {
  MaterialPackage p;
  p.description = TestDescription();
  p.mdf = TestMdf();
  p.full_btf = TestFullBtf();
  p.factored_btf = TestFactoredBtf(core::BtfFactorLayout::kPaper, core::BtfFactorColor::kYCbCr, 2);
  p.ambient = TestAmbient();
  p.error_report = nlohmann::json{{"mdf_rms_error_mm", 0.012}, {"btf_psnr_db", 41.5}};
  return p;
}

// Same distance, or the same special value.
inline bool SameMdfValue(float a, float b) {
  if (core::IsUnknown(a) || core::IsUnknown(b)) return core::IsUnknown(a) && core::IsUnknown(b);
  return a == b;
}

inline void ExpectSameImage(const core::Image& a, const core::Image& b) {
  ASSERT_EQ(a.width(), b.width());
  ASSERT_EQ(a.height(), b.height());
  ASSERT_EQ(a.channels(), b.channels());
  for (std::size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a.data()[i], b.data()[i]) << "value " << i;
}

inline void ExpectSameDirections(const core::SamplingSet& a, const core::SamplingSet& b) {
  ASSERT_EQ(a.size(), b.size());
  for (int i = 0; i < a.size(); ++i) EXPECT_LT((a.direction(i) - b.direction(i)).norm(), 1e-12);
}

inline int CountEntries(const fs::path& dir) {
  int n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

inline std::string Slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

inline void WriteBytes(const fs::path& p, const std::string& bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// Reads every part a package holds, as `mesocap info` then a renderer would.
inline void ReadEverything(const fs::path& dir) {
  const MaterialManifest m = ReadMaterialManifest(dir);
  if (m.mdf) ReadMdf(dir, m);
  if (m.mdf && m.mdf->forms.uint8) ReadQuantizedMdf(dir, m);
  if (m.full_btf) ReadFullBtf(dir, m);
  if (m.factored_btf) ReadFactoredBtf(dir, m);
  if (m.ambient) ReadAmbientTerm(dir, m);
  if (m.error_report) ReadErrorReport(dir, m);
}

// ---------------------------------------------------------------------------
// The MDF and its 8-bit form

}  // namespace mesocap::formats::test_package
