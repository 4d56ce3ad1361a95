#include "formats/material_package.h"

#include <gtest/gtest.h>

#include <Eigen/SVD>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <random>

#include "core/error.h"
#include "core/file_checksum.h"
#include "core/image.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "core/version.h"
#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "tests/common/temporary_directory.h"
#include "tests/formats/test_material_package.h"

namespace mesocap::formats {
namespace {
using namespace test_package;

TEST(Mdf, SpecialValuesAreDistinctAndNeverDistances) {
  EXPECT_TRUE(core::IsNoHit(core::MdfNoHit()));
  EXPECT_FALSE(core::IsUnknown(core::MdfNoHit()));
  EXPECT_TRUE(core::IsUnknown(core::MdfUnknown()));
  EXPECT_FALSE(core::IsNoHit(core::MdfUnknown()));
  for (float d : {0.0f, 1.0f, 1e30f}) {
    EXPECT_FALSE(core::IsNoHit(d));
    EXPECT_FALSE(core::IsUnknown(d));
    EXPECT_TRUE(core::IsValidMdfValue(d));
  }
  EXPECT_FALSE(core::IsValidMdfValue(-0.5f));
  EXPECT_FALSE(core::IsValidMdfValue(-std::numeric_limits<float>::infinity()));
  EXPECT_TRUE(core::IsUnknown(core::MakeMdf(2, 2, TestViews()).at(1, 1, 2)));
}

TEST(Mdf, QuantizationErrorIsAtMostHalfAStep) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> distance(0.0f, 2.5f);
  core::Mdf mdf = core::MakeMdf(32, 16, TestViews());
  for (std::size_t i = 0; i < mdf.distance_mm.size(); ++i) mdf.distance_mm.data()[i] = distance(rng);
  mdf.at(3, 4, 0) = core::MdfNoHit();
  mdf.at(5, 6, 1) = core::MdfUnknown();
  const core::QuantizedMdf q = core::QuantizeMdf(mdf, 1.5);
  float largest = 0;
  for (std::size_t i = 0; i < mdf.distance_mm.size(); ++i) {
    if (std::isfinite(mdf.distance_mm.data()[i])) largest = std::max(largest, mdf.distance_mm.data()[i]);
  }
  EXPECT_DOUBLE_EQ(q.scale_mm, largest / 253.0);
  EXPECT_EQ(q.at(3, 4, 0), core::QuantizedMdf::kNoHitCode);
  EXPECT_EQ(q.at(5, 6, 1), core::QuantizedMdf::kUnknownCode);
  const core::Mdf back = core::DequantizeMdf(q);
  for (std::size_t i = 0; i < mdf.distance_mm.size(); ++i) {
    const float d = mdf.distance_mm.data()[i];
    const float e = back.distance_mm.data()[i];
    if (!std::isfinite(d)) {
      EXPECT_TRUE(SameMdfValue(d, e)) << i;
      continue;
    }
    // scale/2 from rounding, plus the float rounding of the decoded value.
    EXPECT_LE(std::abs(e - d), q.scale_mm / 2 + 2 * std::numeric_limits<float>::epsilon() * d) << i;
  }
}

TEST(Mdf, ScaleFallsBackToDmaxWithoutDistances) {
  core::Mdf mdf = core::MakeMdf(2, 2, TestViews());
  mdf.at(0, 0, 0) = core::MdfNoHit();
  EXPECT_DOUBLE_EQ(core::MdfQuantizationScale(mdf, 1.5), 1.5 / 253);
  mdf.at(1, 0, 0) = 0.0f;
  EXPECT_DOUBLE_EQ(core::MdfQuantizationScale(mdf, 1.5), 1.5 / 253);
  EXPECT_THROW(core::MdfQuantizationScale(mdf, 0.0), core::Error);
}

TEST(Mdf, QuantizeRejectsInvalidValues) {
  core::Mdf mdf = core::MakeMdf(2, 2, TestViews());
  mdf.at(1, 1, 1) = -0.25f;
  EXPECT_THROW(core::QuantizeMdf(mdf, 1.0), core::Error);
  mdf.at(1, 1, 1) = -std::numeric_limits<float>::infinity();
  EXPECT_THROW(core::QuantizeMdf(mdf, 1.0), core::Error);
}

TEST(Mdf, EveryCodeSurvivesTheEightBitFile) {
  testing::TemporaryDirectory dir;
  MaterialDescription d = TestDescription();
  d.width = 16;
  d.height = 16;
  d.view_directions = core::SamplingSet::FromAngles("one", {{0.0, 0.0}});
  core::Mdf mdf = core::MakeMdf(16, 16, d.view_directions);
  const double scale = 0.01;
  for (int i = 0; i < 256; ++i) {
    float& v = mdf.at(i % 16, i / 16, 0);
    v = i <= 253 ? static_cast<float>(i * scale) : (i == 254 ? core::MdfNoHit() : core::MdfUnknown());
  }
  MaterialPackageWriter writer(dir / "pkg", d, false);
  writer.WriteMdf(mdf, MdfForms{.float32 = false, .uint8 = true});
  const MaterialManifest m = writer.Commit();
  EXPECT_NEAR(m.mdf->scale_mm, scale, 1e-9);
  EXPECT_FALSE(fs::exists(dir / "pkg" / "mdf.exr"));
  const core::QuantizedMdf q = ReadQuantizedMdf(dir / "pkg", m);
  for (int i = 0; i < 256; ++i) EXPECT_EQ(q.at(i % 16, i / 16, 0), i);
  // Without the float form, ReadMdf decodes the 8-bit one.
  const core::Mdf back = ReadMdf(dir / "pkg", m);
  EXPECT_TRUE(core::IsNoHit(back.at(14, 15, 0)));
  EXPECT_TRUE(core::IsUnknown(back.at(15, 15, 0)));
  EXPECT_NEAR(back.at(13, 15, 0), 253 * scale, 1e-6);
}

// ---------------------------------------------------------------------------
// Factored BTF

// T = r_0 c_0^T + r_1 c_1^T built by hand in each layout; the package must
// reconstruct it exactly (dyadic values make every product exact).
TEST(FactoredBtf, ReconstructsAKnownRankTwoBtfExactly) {
  for (core::BtfFactorLayout layout :
       {core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel, core::BtfFactorLayout::kPerView}) {
    SCOPED_TRACE(ToString(layout));
    const core::FactoredBtf btf = TestFactoredBtf(layout, core::BtfFactorColor::kRgb, 2);
    testing::TemporaryDirectory dir;
    MaterialPackage p;
    p.description = TestDescription();
    p.factored_btf = btf;
    WriteMaterialPackage(dir / "pkg", p, false);
    const core::FactoredBtf back = ReadFactoredBtf(dir / "pkg", ReadMaterialManifest(dir / "pkg"));
    ASSERT_EQ(back.rank(), 2);
    for (int v = 0; v < 3; ++v)
      for (int l = 0; l < 4; ++l)
        for (int y = 0; y < kH; ++y)
          for (int x = 0; x < kW; ++x) {
            const bool paper = layout == core::BtfFactorLayout::kPaper;
            const bool per_view = layout == core::BtfFactorLayout::kPerView;
            const int row = paper ? l * kH + y : per_view ? v * kH + y : y;
            const int column = paper ? v : per_view ? l : v * 4 + l;
            const int first = per_view ? 2 * v : 0;  // per_view: view v's c_0, c_1 in rows 2v, 2v + 1
            const Eigen::Vector3f got = back.Reconstruct(x, y, v, l);
            for (int c = 0; c < 3; ++c) {
              const float expected = btf.rows[0].at(x, row, c) * btf.columns.at(column, first, c) +
                                     btf.rows[1].at(x, row, c) * btf.columns.at(column, first + 1, c);
              ASSERT_EQ(got[c], expected) << "x=" << x << " y=" << y << " v=" << v << " l=" << l;
            }
          }
  }
}

// The clustered layout: three clusters, each texel reading its own cluster's
// row of column factors; the ids round-trip, and an id out of range in the
// file is an error naming the file and the texel.
TEST(FactoredBtf, ClusteredFactorsRoundTripAndAnOutOfRangeIdIsNamed) {
  core::FactoredBtf btf = TestFactoredBtf(core::BtfFactorLayout::kPerTexel, core::BtfFactorColor::kRgb, 2);
  btf.layout = core::BtfFactorLayout::kClustered;
  btf.cluster_count = 3;
  btf.texel_clusters.resize(kW * kH);
  for (int i = 0; i < kW * kH; ++i) btf.texel_clusters[i] = (i * 7) % 3;
  btf.columns = core::Image(btf.column_count(), 2 * 3, 3);
  for (int r = 0; r < 6; ++r)
    for (int i = 0; i < btf.column_count(); ++i)
      for (int c = 0; c < 3; ++c) btf.columns.at(i, r, c) = Dyadic(i, r, c, 2) + 0.5f;
  testing::TemporaryDirectory dir;
  MaterialPackage p;
  p.description = TestDescription();
  p.factored_btf = btf;
  WriteMaterialPackage(dir / "pkg", p, false);
  const MaterialManifest m = ReadMaterialManifest(dir / "pkg");
  ASSERT_TRUE(m.factored_btf);
  EXPECT_EQ(m.factored_btf->layout, core::BtfFactorLayout::kClustered);
  EXPECT_EQ(m.factored_btf->clusters, 3);
  const core::FactoredBtf back = ReadFactoredBtf(dir / "pkg", m);
  EXPECT_EQ(back.texel_clusters, btf.texel_clusters);
  for (int v = 0; v < 3; ++v)
    for (int l = 0; l < 4; ++l)
      for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x) {
          const int cluster = btf.texel_clusters[y * kW + x];
          const Eigen::Vector3f got = back.Reconstruct(x, y, v, l);
          for (int c = 0; c < 3; ++c) {
            const float expected = btf.rows[0].at(x, y, c) * btf.columns.at(v * 4 + l, cluster * 2, c) +
                                   btf.rows[1].at(x, y, c) * btf.columns.at(v * 4 + l, cluster * 2 + 1, c);
            ASSERT_EQ(got[c], expected) << "x=" << x << " y=" << y << " v=" << v << " l=" << l;
          }
        }

  // A cluster id of 3 among 3 clusters, written over the file with its
  // checksum refreshed so that only the id is wrong.
  btf.texel_clusters[5] = 3;
  EXPECT_THROW(btf.CheckShape(), core::Error);
  core::Image ids(kW, kH, 1);
  for (int i = 0; i < kW * kH; ++i) ids.data()[i] = static_cast<float>(btf.texel_clusters[i]);
  core::WriteImage(dir / "pkg" / "btf/clusters.exr", ids, core::PixelEncoding::kFloat32);
  MaterialManifest refreshed = m;
  refreshed.checksums["btf/clusters.exr"] = core::ComputeFileChecksum(dir / "pkg" / "btf/clusters.exr");
  try {
    ReadFactoredBtf(dir / "pkg", refreshed);
    ADD_FAILURE() << "cluster id 3 of 3 clusters was read";
  } catch (const core::FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("clusters.exr"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("texel 0,1"), std::string::npos) << e.what();
  }
}

// The layouts as the format documents them: factor the BTF matrix with an
// SVD, store the full-rank factors, and get the BTF back.
core::FactoredBtf FactorBySvd(const core::FullBtf& full, core::BtfFactorLayout layout, core::BtfFactorColor color) {
  core::FactoredBtf btf;
  btf.width = full.width;
  btf.height = full.height;
  btf.views = full.views;
  btf.lights = full.lights;
  btf.layout = layout;
  btf.color = color;
  if (color == core::BtfFactorColor::kYCbCr) btf.rgb_to_factored = core::YCbCrFromLinearRgbBt601();
  const int W = full.width, H = full.height, V = full.view_count(), L = full.light_count();
  const bool paper = layout == core::BtfFactorLayout::kPaper;
  const int rows = paper ? W * H * L : W * H;
  const int columns = paper ? V : V * L;
  const int rank = std::min(rows, columns);
  auto row_of = [&](int x, int y, int l) { return paper ? (l * H + y) * W + x : y * W + x; };
  auto column_of = [&](int v, int l) { return paper ? v : v * L + l; };
  for (int k = 0; k < rank; ++k) btf.rows.emplace_back(W, btf.row_image_height(), 3);
  btf.columns = core::Image(columns, rank, 3);
  for (int c = 0; c < 3; ++c) {
    Eigen::MatrixXd a(rows, columns);
    for (int v = 0; v < V; ++v)
      for (int l = 0; l < L; ++l)
        for (int y = 0; y < H; ++y)
          for (int x = 0; x < W; ++x) {
            const Eigen::Vector3d rgb = full.at(x, y, v, l).cast<double>();
            a(row_of(x, y, l), column_of(v, l)) = (btf.rgb_to_factored * rgb)[c];
          }
    Eigen::JacobiSVD<Eigen::MatrixXd> svd(a, Eigen::ComputeThinU | Eigen::ComputeThinV);
    for (int k = 0; k < rank; ++k) {
      for (int r = 0; r < rows; ++r) {
        // Singular values folded into the rows (the format's convention).
        const float value = static_cast<float>(svd.singularValues()[k] * svd.matrixU()(r, k));
        btf.rows[k].at(r % W, r / W, c) = value;
      }
      for (int j = 0; j < columns; ++j) btf.columns.at(j, k, c) = static_cast<float>(svd.matrixV()(j, k));
    }
  }
  return btf;
}

TEST(FactoredBtf, SvdFactorsInEachLayoutAndColourReconstructTheBtf) {
  const core::FullBtf full = TestFullBtf();
  for (core::BtfFactorLayout layout : {core::BtfFactorLayout::kPaper, core::BtfFactorLayout::kPerTexel}) {
    for (core::BtfFactorColor color : {core::BtfFactorColor::kRgb, core::BtfFactorColor::kYCbCr}) {
      SCOPED_TRACE(std::string(ToString(layout)) + " " + ToString(color));
      testing::TemporaryDirectory dir;
      MaterialPackage p;
      p.description = TestDescription();
      p.factored_btf = FactorBySvd(full, layout, color);
      WriteMaterialPackage(dir / "pkg", p, false);
      const MaterialManifest m = ReadMaterialManifest(dir / "pkg");
      ASSERT_TRUE(m.factored_btf);
      EXPECT_EQ(m.factored_btf->layout, layout);
      EXPECT_EQ(m.factored_btf->color, color);
      EXPECT_TRUE(m.factored_btf->rgb_to_factored.isApprox(p.factored_btf->rgb_to_factored, 1e-15));
      const core::FactoredBtf back = ReadFactoredBtf(dir / "pkg", m);
      float worst = 0;
      for (int v = 0; v < 3; ++v)
        for (int l = 0; l < 4; ++l)
          for (int y = 0; y < kH; ++y)
            for (int x = 0; x < kW; ++x) {
              worst = std::max(worst, (back.Reconstruct(x, y, v, l) - full.at(x, y, v, l)).cwiseAbs().maxCoeff());
            }
      EXPECT_LT(worst, 1e-5f);
    }
  }
}

TEST(FactoredBtf, CheckShapeRejectsInconsistentFactors) {
  core::FactoredBtf btf = TestFactoredBtf(core::BtfFactorLayout::kPaper, core::BtfFactorColor::kRgb, 2);
  EXPECT_NO_THROW(btf.CheckShape());
  core::FactoredBtf wrong = btf;
  wrong.columns = core::Image(4, 2, 3);  // paper: one column per view (3)
  EXPECT_THROW(wrong.CheckShape(), core::Error);
  wrong = btf;
  wrong.rows[1] = core::Image(kW, kH, 3);  // paper rows are H * Nlight tall
  EXPECT_THROW(wrong.CheckShape(), core::Error);
  wrong = btf;
  wrong.color = core::BtfFactorColor::kYCbCr;
  wrong.rgb_to_factored = Eigen::Matrix3d::Ones();
  EXPECT_THROW(wrong.CheckShape(), core::Error);
  wrong = TestFactoredBtf(core::BtfFactorLayout::kPaper, core::BtfFactorColor::kRgb, 4);  // rank 4 > 3 columns
  EXPECT_THROW(wrong.CheckShape(), core::Error);
}

// ---------------------------------------------------------------------------
// Round trips

TEST(MaterialPackage, EveryPartRoundTrips) {
  testing::TemporaryDirectory dir;
  const MaterialPackage p = FullTestPackage();
  WriteMaterialPackage(dir / "pkg", p, false);
  EXPECT_EQ(CountEntries(dir.path()), 1) << "temporary folder left behind";

  const MaterialManifest m = ReadMaterialManifest(dir / "pkg");
  const MaterialDescription& d = m.description;
  EXPECT_EQ(d.name, "weave");
  EXPECT_EQ(d.width, kW);
  EXPECT_EQ(d.height, kH);
  EXPECT_EQ(d.physical_size_mm, Eigen::Vector2d(10.0, 8.0));
  EXPECT_EQ(d.d_max_mm, 1.5);
  ExpectSameDirections(d.view_directions, TestViews());
  ExpectSameDirections(d.light_directions, TestLights());
  EXPECT_EQ(d.provenance.software_version, core::Version());
  EXPECT_EQ(d.provenance.created_utc.size(), 20u) << d.provenance.created_utc;  // 2025-01-31T18:04:05Z
  EXPECT_EQ(d.provenance.source, "groundtruth scene=weave rig=small");
  EXPECT_EQ(d.provenance.texel_samples_per_side, 4);
  ASSERT_TRUE(m.mdf);
  EXPECT_TRUE(m.mdf->forms.float32 && m.mdf->forms.uint8);
  EXPECT_TRUE(m.full_btf);
  EXPECT_TRUE(m.factored_btf && m.ambient && m.error_report);

  const MaterialPackage back = ReadMaterialPackage(dir / "pkg");
  // MDF, float form: exact, specials kept.
  ASSERT_TRUE(back.mdf);
  for (int v = 0; v < 3; ++v)
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) EXPECT_TRUE(SameMdfValue(back.mdf->at(x, y, v), p.mdf->at(x, y, v)));
  EXPECT_TRUE(core::IsNoHit(back.mdf->at(0, 0, 1)));
  EXPECT_TRUE(core::IsUnknown(back.mdf->at(2, 1, 0)));
  // MDF, 8-bit form: within scale/2, specials kept.
  const core::QuantizedMdf q = ReadQuantizedMdf(dir / "pkg", m);
  EXPECT_DOUBLE_EQ(q.scale_mm, core::MdfQuantizationScale(*p.mdf, 1.5));
  const core::Mdf decoded = core::DequantizeMdf(q);
  for (int v = 0; v < 3; ++v)
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        const float a = p.mdf->at(x, y, v), b = decoded.at(x, y, v);
        if (std::isfinite(a)) {
          EXPECT_LE(std::abs(a - b), q.scale_mm / 2 + 1e-6);
        } else {
          EXPECT_TRUE(SameMdfValue(a, b));
        }
      }
  EXPECT_EQ(q.at(4, 3, 2), core::QuantizedMdf::kNoHitCode);
  EXPECT_EQ(q.at(2, 1, 0), core::QuantizedMdf::kUnknownCode);
  // BTF, both forms; ambient; error report.
  ASSERT_TRUE(back.full_btf);
  for (int v = 0; v < 3; ++v) ExpectSameImage(back.full_btf->view_images[v], p.full_btf->view_images[v]);
  ASSERT_TRUE(back.factored_btf);
  EXPECT_EQ(back.factored_btf->layout, core::BtfFactorLayout::kPaper);
  EXPECT_EQ(back.factored_btf->color, core::BtfFactorColor::kYCbCr);
  ExpectSameImage(back.factored_btf->columns, p.factored_btf->columns);
  for (int k = 0; k < 2; ++k) ExpectSameImage(back.factored_btf->rows[k], p.factored_btf->rows[k]);
  ASSERT_TRUE(back.ambient);
  ExpectSameImage(back.ambient->values, p.ambient->values);
  EXPECT_EQ(back.ambient->at(1, 2, 2), p.ambient->at(1, 2, 2));
  ASSERT_TRUE(back.error_report);
  EXPECT_EQ(*back.error_report, *p.error_report);
}

TEST(MaterialPackage, AnySubsetOfPartsIsAPackage) {
  testing::TemporaryDirectory dir;
  MaterialPackage p;
  p.description = TestDescription();
  WriteMaterialPackage(dir / "empty", p, false);
  const MaterialManifest empty = ReadMaterialManifest(dir / "empty");
  EXPECT_FALSE(empty.mdf || empty.full_btf || empty.factored_btf || empty.ambient || empty.error_report);
  EXPECT_THROW(ReadMdf(dir / "empty", empty), core::FormatError);
  EXPECT_THROW(ReadFullBtfView(dir / "empty", empty, 0), core::FormatError);
  EXPECT_THROW(ReadAmbientTerm(dir / "empty", empty), core::FormatError);

  p.mdf = TestMdf();  // the ground-truth MDF-only package
  p.mdf_forms.uint8 = false;
  WriteMaterialPackage(dir / "mdf-only", p, false);
  const MaterialManifest m = ReadMaterialManifest(dir / "mdf-only");
  ASSERT_TRUE(m.mdf);
  EXPECT_FALSE(m.mdf->forms.uint8);
  EXPECT_FALSE(fs::exists(dir / "mdf-only" / "mdf8.tif"));
  EXPECT_THROW(ReadQuantizedMdf(dir / "mdf-only", m), core::FormatError);
  EXPECT_TRUE(SameMdfValue(ReadMdf(dir / "mdf-only", m).at(2, 1, 0), core::MdfUnknown()));
}

// A measured MDF's per-texel confidence: stored exactly beside the MDF, only
// after it, only in [0, 1] and in the MDF's layout; a bad file is an error
// naming the file and the texel.
TEST(MaterialPackage, MdfConfidenceRoundTripsAndIsChecked) {
  testing::TemporaryDirectory dir;
  const MaterialDescription d = TestDescription();
  const core::Mdf mdf = TestMdf();
  core::Image confidence(mdf.distance_mm.width(), mdf.distance_mm.height(), 1, 0.0f);
  for (std::size_t i = 0; i < confidence.size(); ++i) confidence.data()[i] = static_cast<float>(i % 7) / 6.0f;
  {
    MaterialPackageWriter writer(dir / "pkg", d, false);
    EXPECT_THROW(writer.WriteMdfConfidence(confidence), core::Error) << "before the MDF";
    writer.WriteMdf(mdf);
    core::Image bad = confidence;
    bad.data()[5] = 1.5f;
    EXPECT_THROW(writer.WriteMdfConfidence(bad), core::Error);
    bad.data()[5] = std::nanf("");
    EXPECT_THROW(writer.WriteMdfConfidence(bad), core::Error);
    EXPECT_THROW(writer.WriteMdfConfidence(core::Image(kW, kH, 1)), core::Error) << "one view's size";
    writer.WriteMdfConfidence(confidence);
    writer.Commit();
  }
  const MaterialManifest m = ReadMaterialManifest(dir / "pkg");
  ASSERT_TRUE(m.mdf);
  EXPECT_TRUE(m.mdf->confidence);
  ExpectSameImage(ReadMdfConfidence(dir / "pkg", m), confidence);

  core::Image mutated = confidence;
  mutated.at(1, kH + 2) = 2.0f;  // view 1, texel (1, 2)
  core::WriteImage(dir / "pkg" / "mdf_confidence.exr", mutated, core::PixelEncoding::kFloat32);
  EXPECT_THROW(ReadMdfConfidence(dir / "pkg", m), core::FormatError) << "the checksum differs";
  MaterialManifest unchecked = m;  // as a version 1 package, without checksums
  unchecked.checksums.clear();
  try {
    ReadMdfConfidence(dir / "pkg", unchecked);
    ADD_FAILURE() << "expected a FormatError";
  } catch (const core::FormatError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("mdf_confidence.exr"), std::string::npos) << what;
    EXPECT_NE(what.find("view 1, texel (1, 2)"), std::string::npos) << what;
  }
  fs::remove(dir / "pkg" / "mdf_confidence.exr");
  EXPECT_THROW(ReadMaterialManifest(dir / "pkg"), core::FormatError) << "the manifest names a missing file";
}

TEST(MaterialPackage, FullBtfIsWrittenAndReadViewByView) {
  testing::TemporaryDirectory dir;
  const core::FullBtf full = TestFullBtf();
  MaterialPackageWriter writer(dir / "pkg", TestDescription(), false);
  for (int v = 2; v >= 0; --v) writer.WriteFullBtfView(v, full.view_images[v]);
  EXPECT_THROW(writer.WriteFullBtfView(1, full.view_images[1]), core::Error);  // twice
  EXPECT_THROW(writer.WriteFullBtfView(3, full.view_images[0]), core::Error);  // no such view
  EXPECT_FALSE(fs::exists(dir / "pkg")) << "visible before Commit";
  const MaterialManifest m = writer.Commit();
  EXPECT_THROW(writer.WriteAmbientTerm(TestAmbient()), core::Error);  // after Commit
  ASSERT_TRUE(m.full_btf);
  for (int v = 0; v < 3; ++v) {
    const core::Image view = ReadFullBtfView(dir / "pkg", m, v);
    EXPECT_EQ(view.width(), kW);
    EXPECT_EQ(view.height(), kH * 4);
    ExpectSameImage(view, full.view_images[v]);
  }
  EXPECT_THROW(ReadFullBtfView(dir / "pkg", m, 3), core::Error);
  EXPECT_EQ(fs::path(FullBtfViewFile(7)).generic_string(), "btf/view_0007.exr");
  EXPECT_EQ(fs::path(BtfRowFactorFile(3)).generic_string(), "btf/rows_03.exr");
}

TEST(MaterialPackage, CommitRefusesAnIncompleteFullBtf) {
  testing::TemporaryDirectory dir;
  {
    MaterialPackageWriter writer(dir / "pkg", TestDescription(), false);
    writer.WriteFullBtfView(0, TestFullBtf().view_images[0]);
    EXPECT_THROW(writer.Commit(), core::Error);
  }
  EXPECT_EQ(CountEntries(dir.path()), 0);
}

TEST(MaterialPackage, WriterRejectsPartsThatDoNotMatchTheDescription) {
  testing::TemporaryDirectory dir;
  MaterialPackageWriter writer(dir / "pkg", TestDescription(), false);
  core::Mdf mdf = core::MakeMdf(kW + 1, kH, TestViews());
  EXPECT_THROW(writer.WriteMdf(mdf), core::Error);
  mdf = core::MakeMdf(kW, kH, TestLights());
  EXPECT_THROW(writer.WriteMdf(mdf), core::Error);
  mdf = TestMdf();
  mdf.at(1, 1, 1) = -1.0f;
  EXPECT_THROW(writer.WriteMdf(mdf), core::Error);
  EXPECT_THROW(writer.WriteMdf(TestMdf(), MdfForms{.float32 = false, .uint8 = false}), core::Error);
  core::Image view = TestFullBtf().view_images[0];
  view.at(0, 0, 1) = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(writer.WriteFullBtfView(0, view), core::Error);
  EXPECT_THROW(writer.WriteFullBtfView(0, core::Image(kW, kH, 3)), core::Error);
  core::FactoredBtf factored = TestFactoredBtf(core::BtfFactorLayout::kPerTexel, core::BtfFactorColor::kRgb, 2);
  factored.lights = TestViews();
  EXPECT_THROW(writer.WriteFactoredBtf(factored), core::Error);
  AmbientTerm ambient = TestAmbient();
  ambient.values = core::Image(kW, kH * 3, 1);
  EXPECT_THROW(writer.WriteAmbientTerm(ambient), core::Error);
  EXPECT_THROW(writer.WriteErrorReport(nlohmann::json::array()), core::Error);
  // The good parts still go in.
  writer.WriteMdf(TestMdf());
  EXPECT_THROW(writer.WriteMdf(TestMdf()), core::Error);
  writer.Commit();
  EXPECT_TRUE(ReadMaterialManifest(dir / "pkg").mdf);

  MaterialDescription bad = TestDescription();
  bad.d_max_mm = 0;
  EXPECT_THROW(MaterialPackageWriter(dir / "bad", bad, false), core::Error);
  bad = TestDescription();
  bad.width = core::kMaxImageSide + 1;
  EXPECT_THROW(MaterialPackageWriter(dir / "bad", bad, false), core::Error);
  EXPECT_FALSE(fs::exists(dir / "bad"));
}

// ---------------------------------------------------------------------------
// Replacing and failing

TEST(MaterialPackage, ReplacesAnExistingPackageOnlyWhenAsked) {
  testing::TemporaryDirectory dir;
  MaterialPackage a = FullTestPackage();
  WriteMaterialPackage(dir / "pkg", a, false);
  MaterialPackage b;
  b.description = TestDescription();
  b.description.name = "replacement";
  b.mdf = TestMdf();
  EXPECT_THROW(WriteMaterialPackage(dir / "pkg", b, false), core::Error);
  EXPECT_EQ(ReadMaterialManifest(dir / "pkg").description.name, "weave");
  WriteMaterialPackage(dir / "pkg", b, true);
  const MaterialManifest m = ReadMaterialManifest(dir / "pkg");
  EXPECT_EQ(m.description.name, "replacement");
  EXPECT_FALSE(m.full_btf || m.ambient);
  EXPECT_FALSE(fs::exists(dir / "pkg" / "btf")) << "files of the old package survived";
  EXPECT_EQ(CountEntries(dir.path()), 1);
}

TEST(MaterialPackage, FailedWriteKeepsTheOldPackage) {
  testing::TemporaryDirectory dir;
  WriteMaterialPackage(dir / "pkg", FullTestPackage(), false);
  const std::string manifest_before = Slurp(dir / "pkg" / "manifest.json");
  MaterialPackage bad = FullTestPackage();
  bad.description.name = "broken";
  bad.ambient->values.at(2, 2, 2) = std::numeric_limits<float>::infinity();  // fails after MDF and BTF
  EXPECT_THROW(WriteMaterialPackage(dir / "pkg", bad, true), core::Error);
  EXPECT_EQ(Slurp(dir / "pkg" / "manifest.json"), manifest_before);
  EXPECT_NO_THROW(ReadEverything(dir / "pkg"));
  EXPECT_EQ(CountEntries(dir.path()), 1) << "partial output left behind";
}

// ---------------------------------------------------------------------------
// Hostile input: every failure is a mesocap::Error naming the file, no crash,
// no allocation of what the input claims.

}  // namespace
}  // namespace mesocap::formats
