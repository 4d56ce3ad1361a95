#include "formats/material_manifest.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/file_checksum.h"
#include "core/image.h"
#include "core/json_field_reader.h"
#include "core/mdf.h"
#include "formats/material_package_layout.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
namespace {

constexpr char kMaterialFormat[] = "mesocap.material";
constexpr int kMaterialVersion = 2;  // version 1: no "files" checksums
constexpr int kOldestMaterialVersion = 1;
constexpr char kBtfValues[] = "linear_rgb_reflectance";
constexpr char kSingularValues[] = "folded_into_rows";

std::string BytesText(double bytes) {
  const char* units[] = {"bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
  int u = 0;
  while (bytes >= 1024 && u < 6) {
    bytes /= 1024;
    ++u;
  }
  std::ostringstream s;
  s.precision(3);
  s << bytes << " " << units[u];
  return s.str();
}

nlohmann::ordered_json MatrixJson(const Eigen::Matrix3d& m) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (int r = 0; r < 3; ++r) rows.push_back({m(r, 0), m(r, 1), m(r, 2)});
  return rows;
}

// Keys in reading order (format and version first) for people and diffs.
nlohmann::ordered_json ManifestJson(const MaterialManifest& m) {
  const MaterialDescription& d = m.description;
  nlohmann::ordered_json j;
  j["format"] = kMaterialFormat;
  j["version"] = kMaterialVersion;
  j["units"] = {{"length", "mm"}, {"angle", "deg"}};
  j["name"] = d.name;
  j["texture_size"] = {d.width, d.height};
  j["physical_size_mm"] = {d.physical_size_mm.x(), d.physical_size_mm.y()};
  j["d_max_mm"] = d.d_max_mm;
  j["view_directions"] = nlohmann::ordered_json(ToJson(d.view_directions));
  j["light_directions"] = nlohmann::ordered_json(ToJson(d.light_directions));
  j["provenance"] = {{"software_version", d.provenance.software_version},
                     {"created_utc", d.provenance.created_utc},
                     {"source", d.provenance.source}};
  if (d.provenance.texel_samples_per_side > 0) {
    j["provenance"]["texel_samples_per_side"] = d.provenance.texel_samples_per_side;
  }
  if (m.mdf) {
    nlohmann::ordered_json mdf = nlohmann::ordered_json::object();
    if (m.mdf->forms.float32) mdf["float32"] = {{"file", kMdfFloatFile}};
    if (m.mdf->forms.uint8) {
      mdf["uint8"] = {{"file", kMdfUint8File},
                      {"scale_mm", m.mdf->scale_mm},
                      {"max_distance_code", core::QuantizedMdf::kMaxDistanceCode},
                      {"no_hit_code", core::QuantizedMdf::kNoHitCode},
                      {"unknown_code", core::QuantizedMdf::kUnknownCode}};
    }
    if (m.mdf->confidence) mdf["confidence"] = {{"file", kMdfConfidenceFile}};
    j["mdf"] = mdf;
  }
  if (m.full_btf || m.factored_btf) {
    nlohmann::ordered_json btf = {{"values", kBtfValues}};
    if (m.full_btf) btf["full"] = {{"files", kFullBtfFiles}};
    if (m.factored_btf) {
      const auto& f = *m.factored_btf;
      nlohmann::ordered_json factored = {
          {"layout", ToString(f.layout)},       {"color", ToString(f.color)},   {"rank", f.rank},
          {"singular_values", kSingularValues}, {"row_files", kRowFactorFiles}, {"column_file", kColumnFactorFile}};
      if (f.color == core::BtfFactorColor::kYCbCr) factored["rgb_to_factored"] = MatrixJson(f.rgb_to_factored);
      if (f.layout == core::BtfFactorLayout::kClustered) {
        factored["clusters"] = f.clusters;
        factored["cluster_file"] = kClusterFile;
      }
      btf["factored"] = factored;
    }
    j["btf"] = btf;
  }
  if (m.ambient) j["ambient"] = {{"file", kAmbientFile}};
  if (m.error_report) j["error_report"] = {{"file", kErrorReportFile}};
  if (m.calibration) j["calibration"] = {{"file", kCalibrationFile}};
  nlohmann::ordered_json files = nlohmann::ordered_json::object();
  for (const auto& [name, sum] : m.checksums) {
    files[name] = {{"bytes", sum.bytes}, {"xxh3_64", core::ChecksumText(sum.xxh3)}};
  }
  j["files"] = files;
  return j;
}

// ---------------------------------------------------------------------------
// Reading the manifest

int ReadTexelCount(const core::JsonFieldReader& r, const std::string& key, const nlohmann::json& value) {
  const std::string expected = "expected an integer in [1, " + std::to_string(core::kMaxImageSide) + "]";
  if (!value.is_number_integer()) r.Fail(key, expected + ", got " + value.dump());
  const double x = value.get<double>();  // exact for every integer in range; out-of-range ones stay out
  if (x < 1 || x > core::kMaxImageSide) r.Fail(key, expected + ", got " + value.dump());
  return static_cast<int>(x);
}

Eigen::Vector2i ReadTextureSize(const core::JsonFieldReader& r) {
  const auto& v = r.Raw("texture_size");
  if (!v.is_array() || v.size() != 2) {
    r.Fail("texture_size", "expected [width, height] in texels, got " + v.dump().substr(0, 40));
  }
  return {ReadTexelCount(r, "texture_size[0]", v[0]), ReadTexelCount(r, "texture_size[1]", v[1])};
}

double ReadPositive(const core::JsonFieldReader& r, const std::string& key, double value) {
  if (!(value > 0)) r.Fail(key, "expected a positive number, got " + NumberText(value));
  return value;
}

core::SamplingSet ReadDirections(const core::JsonFieldReader& r, const char* key) {
  core::SamplingSet set = core::ReadSamplingSet(r.Object(key));
  if (set.size() < 1 || set.size() > kMaxDirections) {
    r.Fail(key, "expected 1 to " + std::to_string(kMaxDirections) + " directions, got " + std::to_string(set.size()));
  }
  return set;
}

Eigen::Matrix3d ReadMatrix3(const core::JsonFieldReader& r, const char* key) {
  const auto& v = r.Raw(key);
  if (!v.is_array() || v.size() != 3) r.Fail(key, "expected 3 rows of 3 numbers");
  Eigen::Matrix3d m;
  for (int i = 0; i < 3; ++i) {
    const std::string row = std::string(key) + "[" + std::to_string(i) + "]";
    if (!v[i].is_array() || v[i].size() != 3) r.Fail(row, "expected a row of 3 numbers");
    for (int j = 0; j < 3; ++j) {
      const auto& e = v[i][j];
      if (!e.is_number() || !std::isfinite(e.get<double>())) {
        r.Fail(row + "[" + std::to_string(j) + "]", "expected a finite number, got " + e.dump());
      }
      m(i, j) = e.get<double>();
    }
  }
  return m;
}

MaterialManifest::MdfPart ReadMdfPart(const core::JsonFieldReader& mdf) {
  MaterialManifest::MdfPart part;
  mdf.RejectUnknownMembers({"float32", "uint8", "confidence"});
  part.forms.float32 = mdf.Has("float32");
  part.forms.uint8 = mdf.Has("uint8");
  if (!part.forms.float32 && !part.forms.uint8) mdf.Fail("", "expected a \"float32\" and/or a \"uint8\" form");
  if (part.forms.float32) {
    mdf.Object("float32").RejectUnknownMembers({"file"});
    mdf.Object("float32").Choice("file", {kMdfFloatFile});
  }
  if (part.forms.uint8) {
    const core::JsonFieldReader u = mdf.Object("uint8");
    u.RejectUnknownMembers({"file", "scale_mm", "max_distance_code", "no_hit_code", "unknown_code"});
    u.Choice("file", {kMdfUint8File});
    part.scale_mm = ReadPositive(u, "scale_mm", u.Number("scale_mm"));
    u.Integer("max_distance_code", core::QuantizedMdf::kMaxDistanceCode, core::QuantizedMdf::kMaxDistanceCode);
    u.Integer("no_hit_code", core::QuantizedMdf::kNoHitCode, core::QuantizedMdf::kNoHitCode);
    u.Integer("unknown_code", core::QuantizedMdf::kUnknownCode, core::QuantizedMdf::kUnknownCode);
  }
  part.confidence = mdf.Has("confidence");
  if (part.confidence) {
    mdf.Object("confidence").RejectUnknownMembers({"file"});
    mdf.Object("confidence").Choice("file", {kMdfConfidenceFile});
  }
  return part;
}

MaterialManifest::FactoredBtfPart ReadFactoredPart(const core::JsonFieldReader& f, const MaterialDescription& d) {
  MaterialManifest::FactoredBtfPart part;
  f.RejectUnknownMembers({"layout", "color", "rank", "singular_values", "row_files", "column_file", "rgb_to_factored",
                          "clusters", "cluster_file"});
  part.layout =
      *core::EnumFromString<core::BtfFactorLayout>(f.Choice("layout", {"paper", "per_texel", "clustered", "per_view"}));
  part.color = f.Choice("color", {"rgb", "ycbcr"}) == "rgb" ? core::BtfFactorColor::kRgb : core::BtfFactorColor::kYCbCr;
  const long long columns = part.layout == core::BtfFactorLayout::kPaper ? d.view_directions.size()
                            : part.layout == core::BtfFactorLayout::kPerView
                                ? d.light_directions.size()
                                : static_cast<long long>(d.view_directions.size()) * d.light_directions.size();
  long long max_rank = std::min<long long>(core::kMaxBtfRank, columns);
  if (part.layout == core::BtfFactorLayout::kPerView) {
    max_rank = std::min<long long>(max_rank, core::kMaxBtfColumnRows / std::max(1, d.view_directions.size()));
  }
  if (part.layout == core::BtfFactorLayout::kClustered) {
    part.clusters = static_cast<int>(f.Integer("clusters", 1, core::kMaxBtfClusters));
    f.Choice("cluster_file", {kClusterFile});
    max_rank = std::min<long long>(max_rank, core::kMaxBtfColumnRows / part.clusters);
  } else {
    for (const char* key : {"clusters", "cluster_file"}) {
      if (f.Has(key)) f.Fail(key, "expected no " + std::string(key) + " but for the clustered layout");
    }
  }
  part.rank = static_cast<int>(f.Integer("rank", 1, max_rank));
  f.Choice("singular_values", {kSingularValues});
  f.Choice("row_files", {kRowFactorFiles});
  f.Choice("column_file", {kColumnFactorFile});
  if (part.color == core::BtfFactorColor::kYCbCr) {
    part.rgb_to_factored = ReadMatrix3(f, "rgb_to_factored");
    const double scale = part.rgb_to_factored.norm();
    if (!(scale > 0) || std::abs(part.rgb_to_factored.determinant()) < 1e-9 * scale * scale * scale) {
      f.Fail("rgb_to_factored", "expected an invertible 3x3 matrix");
    }
  }
  return part;
}

// The data files a manifest lists, each with the manifest field that names it.
std::vector<std::pair<std::string, std::string>> FieldsAndFiles(const MaterialManifest& m) {
  std::vector<std::pair<std::string, std::string>> files;
  if (m.mdf) {
    if (m.mdf->forms.float32) files.emplace_back("mdf.float32.file", kMdfFloatFile);
    if (m.mdf->forms.uint8) files.emplace_back("mdf.uint8.file", kMdfUint8File);
    if (m.mdf->confidence) files.emplace_back("mdf.confidence.file", kMdfConfidenceFile);
  }
  if (m.full_btf) {
    for (int v = 0; v < m.description.view_directions.size(); ++v) {
      files.emplace_back("btf.full.files", FullBtfViewFile(v).generic_string());
    }
  }
  if (m.factored_btf) {
    for (int k = 0; k < m.factored_btf->rank; ++k) {
      files.emplace_back("btf.factored.row_files", BtfRowFactorFile(k).generic_string());
    }
    files.emplace_back("btf.factored.column_file", kColumnFactorFile);
    if (m.factored_btf->layout == core::BtfFactorLayout::kClustered) {
      files.emplace_back("btf.factored.cluster_file", kClusterFile);
    }
  }
  if (m.ambient) files.emplace_back("ambient.file", kAmbientFile);
  if (m.error_report) files.emplace_back("error_report.file", kErrorReportFile);
  if (m.calibration) files.emplace_back("calibration.file", kCalibrationFile);
  return files;
}

void ExpectFiles(const core::JsonFieldReader& root, const MaterialManifest& m, const fs::path& dir) {
  for (const auto& [field, name] : FieldsAndFiles(m)) {
    std::error_code ec;
    if (!fs::is_regular_file(dir / name, ec)) {
      root.Fail(field, "the package has no file " + name + " (" + (dir / name).string() + ")");
    }
  }
}

// "files": every data file the manifest lists, with its size and hash.
std::map<std::string, core::FileChecksum> ReadChecksums(const core::JsonFieldReader& root, const MaterialManifest& m) {
  const nlohmann::json& files = root.Raw("files");
  if (!files.is_object()) root.Fail("files", "expected an object: file name -> {\"bytes\", \"xxh3_64\"}");
  std::map<std::string, core::FileChecksum> sums;
  for (const auto& [field, name] : FieldsAndFiles(m)) {
    if (!files.contains(name)) root.Fail("files", "no checksum of " + name + ", which " + field + " lists");
    const core::JsonFieldReader entry = root.Object("files").Object(name);
    entry.RejectUnknownMembers({"bytes", "xxh3_64"});
    core::FileChecksum sum;
    sum.bytes = static_cast<std::uint64_t>(entry.Integer("bytes", 0, std::int64_t{1} << 62));
    const auto hash = core::ParseChecksumText(entry.String("xxh3_64"));
    if (!hash) entry.Fail("xxh3_64", "expected 16 lowercase hexadecimal digits");
    sum.xxh3 = *hash;
    sums.emplace(name, sum);
  }
  if (files.size() != sums.size()) {
    for (const auto& [name, value] : files.items()) {
      if (!sums.count(name)) root.Fail("files", "lists " + name + ", which is no part of this package");
    }
  }
  return sums;
}

fs::path ManifestPath(const fs::path& dir) { return dir / kManifestFile; }

}  // namespace

// Counted in double: no overflow, and exact near the limit.
std::string OversizeProblem(const MaterialDescription& d, const char* part, bool with_lights, int channels) {
  double values = static_cast<double>(d.width) * d.height * d.view_directions.size() * channels;
  if (with_lights) values *= d.light_directions.size();
  if (values * 4 <= kMaxPartBytes) return {};
  return std::string(part) + " of " + std::to_string(d.width) + "x" + std::to_string(d.height) + " texels x " +
         std::to_string(d.view_directions.size()) + " views" +
         (with_lights ? " x " + std::to_string(d.light_directions.size()) + " lights" : std::string()) + " x " +
         std::to_string(channels) + " channels implies " + BytesText(values * 4) + " of float data; at most " +
         BytesText(kMaxPartBytes) + " accepted";
}

[[noreturn]] void ThrowMissingPart(const fs::path& dir, const char* field, const char* what) {
  throw core::FormatError(ManifestPath(dir), field, std::string("this package has no ") + what);
}

void WriteMaterialManifest(const fs::path& dir, const MaterialManifest& manifest) {
  core::WriteTextFileAtomically(dir / kManifestFile, ManifestJson(manifest).dump(2) + "\n");
}

fs::path FullBtfViewFile(int view) {
  char name[32];
  std::snprintf(name, sizeof name, "view_%04d.exr", view);
  return fs::path("btf") / name;
}

fs::path BtfRowFactorFile(int k) {
  char name[32];
  std::snprintf(name, sizeof name, "rows_%02d.exr", k);
  return fs::path("btf") / name;
}

MaterialManifest ReadMaterialManifest(const fs::path& dir) {
  const fs::path file = ManifestPath(dir);
  const nlohmann::json doc = core::ReadJsonFile(file, kMaxJsonBytes);
  const core::JsonFieldReader root(doc, file);
  MaterialManifest m;
  m.version = root.ExpectFormat(kMaterialFormat, kOldestMaterialVersion, kMaterialVersion);
  root.RejectUnknownMembers({"format", "version", "units", "name", "texture_size", "physical_size_mm", "d_max_mm",
                             "view_directions", "light_directions", "provenance", "mdf", "btf", "ambient",
                             "error_report", "calibration", "files"});
  const core::JsonFieldReader units = root.Object("units");
  units.RejectUnknownMembers({"length", "angle"});
  units.Choice("length", {"mm"});
  units.Choice("angle", {"deg"});

  MaterialDescription& d = m.description;
  d.name = root.String("name");
  const Eigen::Vector2i texels = ReadTextureSize(root);
  d.width = texels.x();
  d.height = texels.y();
  const std::vector<double> physical = root.Numbers("physical_size_mm", 2);
  d.physical_size_mm = {ReadPositive(root, "physical_size_mm[0]", physical[0]),
                        ReadPositive(root, "physical_size_mm[1]", physical[1])};
  d.d_max_mm = ReadPositive(root, "d_max_mm", root.Number("d_max_mm"));
  d.view_directions = ReadDirections(root, "view_directions");
  d.light_directions = ReadDirections(root, "light_directions");
  const core::JsonFieldReader provenance = root.Object("provenance");
  provenance.RejectUnknownMembers({"software_version", "created_utc", "source", "texel_samples_per_side"});
  d.provenance.software_version = provenance.String("software_version");
  d.provenance.created_utc = provenance.String("created_utc");
  d.provenance.source = provenance.String("source");
  if (provenance.Has("texel_samples_per_side")) {
    d.provenance.texel_samples_per_side =
        static_cast<int>(provenance.Integer("texel_samples_per_side", 1, kMaxTexelSamplesPerSide));
  }

  if (root.Has("mdf")) {
    m.mdf = ReadMdfPart(root.Object("mdf"));
    if (auto problem = OversizeProblem(d, "MDF", false, 1); !problem.empty()) root.Fail("mdf", problem);
  }
  if (root.Has("btf")) {
    const core::JsonFieldReader btf = root.Object("btf");
    btf.RejectUnknownMembers({"values", "full", "factored"});
    btf.Choice("values", {kBtfValues});
    m.full_btf = btf.Has("full");
    if (m.full_btf) {
      btf.Object("full").RejectUnknownMembers({"files"});
      btf.Object("full").Choice("files", {kFullBtfFiles});
    }
    if (btf.Has("factored")) m.factored_btf = ReadFactoredPart(btf.Object("factored"), d);
    if (!m.full_btf && !m.factored_btf) btf.Fail("", "expected a \"full\" and/or a \"factored\" form");
    if (auto problem = OversizeProblem(d, "BTF", true, 3); !problem.empty()) root.Fail("btf", problem);
  }
  if (root.Has("ambient")) {
    root.Object("ambient").RejectUnknownMembers({"file"});
    root.Object("ambient").Choice("file", {kAmbientFile});
    m.ambient = true;
    if (auto problem = OversizeProblem(d, "ambient term", false, 3); !problem.empty()) root.Fail("ambient", problem);
  }
  if (root.Has("error_report")) {
    root.Object("error_report").RejectUnknownMembers({"file"});
    root.Object("error_report").Choice("file", {kErrorReportFile});
    m.error_report = true;
  }
  if (root.Has("calibration")) {
    root.Object("calibration").RejectUnknownMembers({"file"});
    root.Object("calibration").Choice("file", {kCalibrationFile});
    m.calibration = true;
  }
  if (m.version >= 2) {
    m.checksums = ReadChecksums(root, m);
  } else if (root.Has("files")) {
    root.Fail("files", "checksums are a version 2 member; this manifest says version 1");
  }
  ExpectFiles(root, m, dir);
  return m;
}

std::vector<std::string> PackageDataFiles(const MaterialManifest& manifest) {
  std::vector<std::string> names;
  for (auto& [field, name] : FieldsAndFiles(manifest)) names.push_back(std::move(name));
  return names;
}

void ExpectPackageFileIntact(const fs::path& dir, const MaterialManifest& manifest, const std::string& name) {
  const auto it = manifest.checksums.find(name);
  if (it != manifest.checksums.end()) core::ExpectFileChecksum(dir / name, it->second);
}

bool IsMaterialPackageFolder(const fs::path& dir) {
  try {
    const nlohmann::json doc = core::ReadJsonFile(ManifestPath(dir), kMaxJsonBytes);
    return doc.is_object() && doc.value("format", "") == kMaterialFormat;
  } catch (const core::Error&) {
    return false;
  }
}

}  // namespace mesocap::formats
