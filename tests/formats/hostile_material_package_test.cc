// The material package's readers against hostile packages: truncated and
// mutated manifests and images, wrong sizes, missing files. Every outcome is
// a success or an error naming a file of the package, and no reader
// allocates what a file claims before checking it.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <random>

#include "core/error.h"
#include "core/file_checksum.h"
#include "core/json_field_reader.h"
#include "core/version.h"
#include "formats/material_manifest.h"
#include "tests/common/largest_allocation.h"
#include "tests/common/temporary_directory.h"
#include "tests/common/trial_count.h"
#include "tests/formats/test_material_package.h"

namespace mesocap::formats {
namespace {
using namespace test_package;

// Far above anything the small test packages need (OpenImageIO's scanline
// reader stages through a fixed 64 MiB buffer), far below what the hostile
// manifests claim (gigabytes).
constexpr std::size_t kAllocationCeiling = 256u << 20;

class HostilePackage : public ::testing::Test {
 protected:
  void SetUp() override {
    pkg_ = dir_ / "pkg";
    WriteMaterialPackage(pkg_, FullTestPackage(), false);
    manifest_text_ = Slurp(pkg_ / "manifest.json");
    manifest_ = nlohmann::json::parse(manifest_text_);
  }

  // Runs the readers; the outcome must be success or an Error whose message
  // names a file of the package. Returns the error (empty on success).
  std::string ReadAndJudge(bool bound_allocation = true) {
    g_largest_allocation = 0;
    std::string message;
    try {
      ReadEverything(pkg_);
    } catch (const core::Error& e) {
      message = e.what();
      EXPECT_NE(message.find(pkg_.string()), std::string::npos) << "no file named: " << message;
    }
    if (bound_allocation) {
      EXPECT_LT(g_largest_allocation.load(), kAllocationCeiling) << message;
    }
    return message;
  }

  // Writes `manifest` and expects a FormatError about `file` and `field`.
  void ExpectManifestRejected(const nlohmann::json& manifest, const std::string& field,
                              const std::string& file = "manifest.json") {
    WriteBytes(pkg_ / "manifest.json", manifest.dump(2));
    ExpectRejected(field, file);
  }

  void ExpectRejected(const std::string& field, const std::string& file) {
    g_largest_allocation = 0;
    try {
      ReadEverything(pkg_);
      ADD_FAILURE() << "accepted; expected an error on " << file << " field " << field;
    } catch (const core::FormatError& e) {
      EXPECT_EQ(e.file(), pkg_ / file) << e.what();
      EXPECT_EQ(e.field(), field) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a FormatError: " << e.what();
    }
    EXPECT_LT(g_largest_allocation.load(), kAllocationCeiling);
  }

  void RestoreManifest() { WriteBytes(pkg_ / "manifest.json", manifest_text_); }

  // The package as a version 1 manifest describes it: no checksums, so a
  // replaced image reaches the decoders' own checks (what also guards a
  // version 2 package whose manifest was edited to match).
  void UseVersion1() {
    manifest_["version"] = 1;
    manifest_.erase("files");
    manifest_text_ = manifest_.dump(2);
    RestoreManifest();
  }

  testing::TemporaryDirectory dir_;
  fs::path pkg_;
  std::string manifest_text_;
  nlohmann::json manifest_;
};

TEST_F(HostilePackage, TheUntouchedPackageReads) { EXPECT_EQ(ReadAndJudge(), ""); }

TEST_F(HostilePackage, TruncatedManifestAtManyOffsets) {
  const std::size_t last_brace = manifest_text_.rfind('}');
  // Every 3rd offset (a few hundred) and every one of the last 8 bytes.
  for (std::size_t keep = 0; keep < manifest_text_.size(); keep += keep + 8 < manifest_text_.size() ? 3 : 1) {
    WriteBytes(pkg_ / "manifest.json", manifest_text_.substr(0, keep));
    const std::string error = ReadAndJudge();
    if (keep <= last_brace) {
      EXPECT_NE(error.find("manifest.json"), std::string::npos) << "kept " << keep;
    }
  }
}

TEST_F(HostilePackage, SingleByteMutationsOfTheManifest) {
  std::mt19937 rng(20050101);
  std::uniform_int_distribution<std::size_t> offset(0, manifest_text_.size() - 1);
  std::uniform_int_distribution<int> byte(0, 255);
  std::string interesting = "0123456789-+.eE\"[]{}:,nNaI \xff";
  interesting.push_back('\0');
  // MESOCAP_MUTATION_TRIALS (default 100) x 6 mutations.
  const int mutations = 6 * testing::TrialCount("MESOCAP_MUTATION_TRIALS", 100);
  int rejected = 0;
  for (int i = 0; i < mutations; ++i) {
    std::string text = manifest_text_;
    const std::size_t at = offset(rng);
    // Half the time a byte that changes the JSON's meaning rather than its syntax.
    text[at] = i % 2 ? static_cast<char>(byte(rng)) : interesting[byte(rng) % interesting.size()];
    WriteBytes(pkg_ / "manifest.json", text);
    if (!ReadAndJudge().empty()) ++rejected;
  }
  EXPECT_GT(rejected, mutations / 2);
}

// No allocation bound here: a mutated EXR header (a huge data window) makes
// OpenEXR allocate (docs/FUZZING.md) inside OpenImageIO's open(), before any
// mesocap code sees the header. The manifest-driven checks above bound what
// mesocap itself allocates. Under the address sanitizer such an allocation
// takes most of a second, so its preset runs fewer
// (MESOCAP_MUTATION_TRIALS mutations per file, default 100).
TEST_F(HostilePackage, SingleByteMutationsOfTheImages) {
  const int mutations = testing::TrialCount("MESOCAP_MUTATION_TRIALS", 100);
  std::mt19937 rng(42);
  for (const char* name : {"mdf.exr", "mdf8.tif", "btf/view_0001.exr", "btf/columns.exr", "ambient.exr"}) {
    SCOPED_TRACE(name);
    const std::string original = Slurp(pkg_ / name);
    std::uniform_int_distribution<std::size_t> offset(0, original.size() - 1);
    std::uniform_int_distribution<int> byte(0, 255);
    for (int i = 0; i < mutations; ++i) {
      std::string bytes = original;
      bytes[offset(rng)] = static_cast<char>(byte(rng));
      WriteBytes(pkg_ / name, bytes);
      ReadAndJudge(/*bound_allocation=*/false);
    }
    WriteBytes(pkg_ / name, original);
  }
}

TEST_F(HostilePackage, WrongFormatOrVersionOrUnits) {
  auto m = manifest_;
  m["format"] = "mesocap.session";
  ExpectManifestRejected(m, "format");
  m = manifest_;
  m["version"] = 3;
  ExpectManifestRejected(m, "version");
  m["version"] = "1";
  ExpectManifestRejected(m, "version");
  m = manifest_;
  m["units"]["length"] = "cm";
  ExpectManifestRejected(m, "units.length");
  m = manifest_;
  m.erase("units");
  ExpectManifestRejected(m, "units");
  for (const nlohmann::json& samples : {nlohmann::json(0), nlohmann::json(65), nlohmann::json(2.5)}) {
    m = manifest_;
    m["provenance"]["texel_samples_per_side"] = samples;
    ExpectManifestRejected(m, "provenance.texel_samples_per_side");
  }
  ExpectManifestRejected(nlohmann::json::array(), "");
}

TEST_F(HostilePackage, BadSizes) {
  const std::vector<std::pair<nlohmann::json, std::string>> texture_sizes = {
      {{0, 4}, "texture_size[0]"},    {{-5, 4}, "texture_size[0]"},
      {{5, 4.5}, "texture_size[1]"},  {{5, 16385}, "texture_size[1]"},
      {{5, 1e12}, "texture_size[1]"}, {{"NaN", 4}, "texture_size[0]"},
      {{5}, "texture_size"},          {"5x4", "texture_size"},
      {{5, 4, 1}, "texture_size"},    {{5, 18446744073709551615ull}, "texture_size[1]"}};
  for (const auto& [value, field] : texture_sizes) {
    SCOPED_TRACE(value.dump());
    auto m = manifest_;
    m["texture_size"] = value;
    ExpectManifestRejected(m, field);
  }
  for (const auto& value : {nlohmann::json{0, 8}, nlohmann::json{-1, 8}, nlohmann::json{"Infinity", 8}}) {
    auto m = manifest_;
    m["physical_size_mm"] = value;
    ExpectManifestRejected(m, "physical_size_mm[0]");
  }
  for (const auto& value : {nlohmann::json(0), nlohmann::json(-1.5), nlohmann::json("nan"), nlohmann::json(nullptr)}) {
    auto m = manifest_;
    m["d_max_mm"] = value;
    ExpectManifestRejected(m, "d_max_mm");
  }
  // Overflowing literals parse to infinity; still refused.
  std::string text = manifest_text_;
  const std::string from = "\"d_max_mm\": 1.5";
  ASSERT_NE(text.find(from), std::string::npos);
  text.replace(text.find(from), from.size(), "\"d_max_mm\": 1e999");
  WriteBytes(pkg_ / "manifest.json", text);
  const std::string error = ReadAndJudge();
  EXPECT_NE(error.find("manifest.json"), std::string::npos) << error;
}

TEST_F(HostilePackage, AbsurdImpliedSizesAreRefusedBeforeReading) {
  UseVersion1();
  // 16384^2 texels x 96 views x 96 lights x RGB: 29 TiB.
  auto m = manifest_;
  m["texture_size"] = {16384, 16384};
  m["view_directions"] = ToJson(core::SamplingSet::RegularGrid(12, 8));
  m["light_directions"] = ToJson(core::SamplingSet::RegularGrid(12, 8));
  m.erase("mdf");
  m.erase("ambient");
  ExpectManifestRejected(m, "btf");
  // 16384^2 texels x 3600 views: 3.5 TiB of MDF.
  m = manifest_;
  m["texture_size"] = {16384, 16384};
  m.erase("btf");
  m.erase("ambient");
  m["view_directions"] = ToJson(core::SamplingSet::RegularGrid(60, 60));
  ExpectManifestRejected(m, "mdf");
  // Plausible sizes that the files do not have: refused on the first image
  // header, before any pixel is allocated.
  m = manifest_;
  m["texture_size"] = {16384, 16384};
  m.erase("btf");
  m.erase("error_report");
  ExpectManifestRejected(m, "width", "mdf.exr");
}

TEST_F(HostilePackage, BadDirectionSets) {
  UseVersion1();
  auto m = manifest_;
  m.erase("view_directions");
  ExpectManifestRejected(m, "view_directions");
  m = manifest_;
  m["light_directions"]["directions_deg"] = nlohmann::json::array();
  ExpectManifestRejected(m, "light_directions.directions_deg");
  m = manifest_;
  m["view_directions"]["directions_deg"][1] = {95.0, 0.0};
  ExpectManifestRejected(m, "view_directions.directions_deg[1]");
  // Fewer views than the images hold: the manifest is fine, the images not.
  m = manifest_;
  m["view_directions"]["directions_deg"].erase(2);
  m.erase("btf");
  m.erase("ambient");
  ExpectManifestRejected(m, "height", "mdf.exr");
}

TEST_F(HostilePackage, BadPartEntries) {
  UseVersion1();
  auto m = manifest_;
  m["mdf"] = nlohmann::json::object();
  ExpectManifestRejected(m, "mdf");
  m = manifest_;
  m["mdf"]["uint8"]["scale_mm"] = 0;
  ExpectManifestRejected(m, "mdf.uint8.scale_mm");
  m["mdf"]["uint8"]["scale_mm"] = "NaN";
  ExpectManifestRejected(m, "mdf.uint8.scale_mm");
  m = manifest_;
  m["mdf"]["uint8"]["no_hit_code"] = 200;
  ExpectManifestRejected(m, "mdf.uint8.no_hit_code");
  m = manifest_;
  m["mdf"]["float32"]["file"] = "../../../etc/passwd";
  ExpectManifestRejected(m, "mdf.float32.file");
  m = manifest_;
  m["btf"]["factored"]["rank"] = 0;
  ExpectManifestRejected(m, "btf.factored.rank");
  m["btf"]["factored"]["rank"] = 4;  // paper layout: at most 3 views
  ExpectManifestRejected(m, "btf.factored.rank");
  m = manifest_;
  m["btf"]["factored"]["layout"] = "diagonal";
  ExpectManifestRejected(m, "btf.factored.layout");
  m = manifest_;
  m["btf"]["factored"]["rgb_to_factored"] = {{1, 0, 0}, {0, 1, 0}, {1, 1, 0}};
  ExpectManifestRejected(m, "btf.factored.rgb_to_factored");
  m["btf"]["factored"]["rgb_to_factored"] = {{1, 0, 0}, {0, 1, 0}, {0, "x", 1}};
  ExpectManifestRejected(m, "btf.factored.rgb_to_factored[2][1]");
  m = manifest_;
  m["btf"]["factored"]["singular_values"] = "separate";
  ExpectManifestRejected(m, "btf.factored.singular_values");
  m = manifest_;
  m["btf"] = {{"values", "linear_rgb_reflectance"}};
  ExpectManifestRejected(m, "btf");
  m = manifest_;
  m["btf"]["values"] = "srgb";
  ExpectManifestRejected(m, "btf.values");
  m = manifest_;
  m["ambient"] = "ambient.exr";
  ExpectManifestRejected(m, "ambient");
  // Rank 1 of the stored 2 is a valid (truncated) package.
  m = manifest_;
  m["btf"]["factored"]["rank"] = 1;
  WriteBytes(pkg_ / "manifest.json", m.dump());
  ExpectRejected("height", "btf/columns.exr");
}

TEST_F(HostilePackage, MissingFiles) {
  const std::vector<std::pair<std::string, std::string>> cases = {{"mdf.exr", "mdf.float32.file"},
                                                                  {"mdf8.tif", "mdf.uint8.file"},
                                                                  {"btf/view_0002.exr", "btf.full.files"},
                                                                  {"btf/rows_01.exr", "btf.factored.row_files"},
                                                                  {"btf/columns.exr", "btf.factored.column_file"},
                                                                  {"ambient.exr", "ambient.file"},
                                                                  {"error_report.json", "error_report.file"}};
  for (const auto& [file, field] : cases) {
    SCOPED_TRACE(file);
    const std::string bytes = Slurp(pkg_ / file);
    fs::remove(pkg_ / file);
    try {
      ReadMaterialManifest(pkg_);
      ADD_FAILURE() << "missing file accepted";
    } catch (const core::FormatError& e) {
      EXPECT_EQ(e.field(), field);
      EXPECT_NE(std::string(e.what()).find(file), std::string::npos) << e.what();
    }
    WriteBytes(pkg_ / file, bytes);
  }
  fs::remove(pkg_ / "manifest.json");
  ExpectRejected("", "manifest.json");
}

TEST_F(HostilePackage, ImagesThatDisagreeWithTheManifest) {
  UseVersion1();
  core::WriteImage(pkg_ / "mdf.exr", core::Image(kW, kH, 1));  // one view's worth
  ExpectRejected("height", "mdf.exr");
  core::WriteImage(pkg_ / "mdf.exr", core::Image(kW, kH * 3, 1), core::PixelEncoding::kHalf);
  ExpectRejected("pixel type", "mdf.exr");
  core::WriteImage(pkg_ / "mdf.exr", TestMdf().distance_mm);
  core::WriteImage(pkg_ / "mdf8.tif", core::Image(kW, kH * 3, 1), core::PixelEncoding::kFloat32);
  ExpectRejected("pixel type", "mdf8.tif");
  core::WriteImage(pkg_ / "mdf8.tif", core::Image(kW, kH * 3, 1), core::PixelEncoding::kUInt8);
  core::WriteImage(pkg_ / "ambient.exr", core::Image(kW, kH * 3, 1));
  ExpectRejected("channels", "ambient.exr");
  core::WriteImage(pkg_ / "ambient.exr", core::Image(kW, kH * 3, 3));
  core::WriteImage(pkg_ / "btf/view_0001.exr", core::Image(kW + 1, kH * 4, 3));
  ExpectRejected("width", "btf/view_0001.exr");
  core::WriteImage(pkg_ / "btf/view_0001.exr", core::Image(kW, kH * 4, 3));
  core::WriteImage(pkg_ / "btf/rows_00.exr", core::Image(kW, kH, 3));  // per_texel-sized rows in a paper package
  ExpectRejected("height", "btf/rows_00.exr");
  EXPECT_NO_THROW(ReadMaterialManifest(pkg_)) << "the manifest reader must not look at pixels";
}

TEST_F(HostilePackage, InvalidValuesInImages) {
  UseVersion1();
  core::Mdf mdf = TestMdf();
  mdf.at(1, 2, 2) = -0.5f;
  core::WriteImage(pkg_ / "mdf.exr", mdf.distance_mm);
  ExpectRejected("pixels", "mdf.exr");
  mdf.at(1, 2, 2) = -std::numeric_limits<float>::infinity();
  core::WriteImage(pkg_ / "mdf.exr", mdf.distance_mm);
  ExpectRejected("pixels", "mdf.exr");
  core::WriteImage(pkg_ / "mdf.exr", TestMdf().distance_mm);
  AmbientTerm ambient = TestAmbient();
  ambient.values.at(0, 5, 1) = std::numeric_limits<float>::quiet_NaN();
  core::WriteImage(pkg_ / "ambient.exr", ambient.values);
  ExpectRejected("pixels", "ambient.exr");
  core::WriteImage(pkg_ / "ambient.exr", TestAmbient().values);
  core::Image columns(3, 2, 3);
  columns.at(2, 1, 0) = std::numeric_limits<float>::infinity();
  core::WriteImage(pkg_ / "btf/columns.exr", columns);
  ExpectRejected("pixels", "btf/columns.exr");
  core::WriteImage(pkg_ / "btf/columns.exr", core::Image(3, 2, 3));
  WriteBytes(pkg_ / "error_report.json", "[1, 2]");
  ExpectRejected("", "error_report.json");
  WriteBytes(pkg_ / "error_report.json", "{\"rms\": ");
  ExpectRejected("", "error_report.json");
}

// A version 2 package records every data file's size and hash: any change
// of one byte (a bit flip in a compressed EXR block decodes without error)
// is refused by the reader that reads the file, naming it.
TEST_F(HostilePackage, EveryByteChangeOfADataFileIsDetected) {
  const MaterialManifest manifest = ReadMaterialManifest(pkg_);
  ASSERT_EQ(manifest.version, 2);
  ASSERT_EQ(manifest.checksums.size(), PackageDataFiles(manifest).size());
  std::mt19937 rng(7);
  for (const std::string& name : PackageDataFiles(manifest)) {
    SCOPED_TRACE(name);
    const std::string original = Slurp(pkg_ / name);
    std::uniform_int_distribution<std::size_t> offset(0, original.size() - 1);
    std::uniform_int_distribution<int> bit(0, 7);
    for (int i = 0; i < 20; ++i) {
      std::string bytes = original;
      bytes[offset(rng)] ^= static_cast<char>(1 << bit(rng));
      WriteBytes(pkg_ / name, bytes);
      ExpectRejected("checksum", name);
    }
    WriteBytes(pkg_ / name, original);
  }
  EXPECT_EQ(ReadAndJudge(), "");
}

TEST_F(HostilePackage, TruncatedImages) {
  for (const char* name : {"mdf.exr", "mdf8.tif", "btf/view_0000.exr", "btf/rows_01.exr", "ambient.exr"}) {
    SCOPED_TRACE(name);
    const std::string original = Slurp(pkg_ / name);
    for (double keep : {0.0, 0.05, 0.3, 0.6, 0.95}) {
      WriteBytes(pkg_ / name, original.substr(0, static_cast<std::size_t>(original.size() * keep)));
      try {
        ReadEverything(pkg_);
        ADD_FAILURE() << "truncated to " << keep << " accepted";
      } catch (const core::FormatError& e) {
        EXPECT_EQ(e.file(), pkg_ / name) << e.what();
      }
    }
    WriteBytes(pkg_ / name, original);
  }
}

}  // namespace
}  // namespace mesocap::formats
