#include "formats/material_package.h"

#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <sstream>

#include "core/error.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "core/version.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
namespace {

constexpr char kFormat[] = "mesocap.material";
constexpr int kVersion = 1;
constexpr std::uintmax_t kMaxJsonBytes = 16u << 20;

// File names are fixed by the format; the manifest repeats them so that other
// tools see what a package holds, and a reader accepts only these (a manifest
// can never point outside its folder).
constexpr char kManifestFile[] = "manifest.json";
constexpr char kMdfFloatFile[] = "mdf.exr";
constexpr char kMdfUint8File[] = "mdf8.tif";
constexpr char kMdfConfidenceFile[] = "mdf_confidence.exr";
constexpr char kFullBtfFiles[] = "btf/view_{view:04d}.exr";
constexpr char kRowFactorFiles[] = "btf/rows_{k:02d}.exr";
constexpr char kColumnFactorFile[] = "btf/columns.exr";
constexpr char kAmbientFile[] = "ambient.exr";
constexpr char kErrorReportFile[] = "error_report.json";
constexpr char kCalibrationFile[] = "calibration.json";
constexpr char kBtfValues[] = "linear_rgb_reflectance";
constexpr char kSingularValues[] = "folded_into_rows";

std::string Text(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

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

std::string SizeText(int width, int height, int channels) {
  return std::to_string(width) + "x" + std::to_string(height) + "x" + std::to_string(channels);
}

std::string CurrentUtcTime() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

// Images pack a direction set along their height (Sec. 5's 3D textures).
int PackedHeight(const MaterialDescription& d, const core::SamplingSet& set) { return d.height * set.size(); }

// Empty when the float data a part implies is plausible, else why not.
// Counted in double: no overflow, and exact near the limit.
std::string OversizeProblem(const MaterialDescription& d, const char* part, bool with_lights, int channels) {
  double values = static_cast<double>(d.width) * d.height * d.view_directions.size() * channels;
  if (with_lights) values *= d.light_directions.size();
  if (values * 4 <= kMaxPartBytes) return {};
  return std::string(part) + " of " + std::to_string(d.width) + "x" + std::to_string(d.height) +
         " texels x " + std::to_string(d.view_directions.size()) + " views" +
         (with_lights ? " x " + std::to_string(d.light_directions.size()) + " lights" : std::string()) +
         " x " + std::to_string(channels) + " channels implies " + BytesText(values * 4) +
         " of float data; at most " + BytesText(kMaxPartBytes) + " accepted";
}

bool SameDirections(const core::SamplingSet& a, const core::SamplingSet& b) {
  if (a.size() != b.size()) return false;
  for (int i = 0; i < a.size(); ++i) {
    if ((a.direction(i) - b.direction(i)).norm() > 1e-9) return false;
  }
  return true;
}

// ---------------------------------------------------------------------------
// Writing

void CheckDescription(const fs::path& dir, const MaterialDescription& d) {
  if (d.width < 1 || d.width > kMaxTextureSize || d.height < 1 || d.height > kMaxTextureSize) {
    throw core::Error(dir.string() + ": texture size " + std::to_string(d.width) + "x" + std::to_string(d.height) +
                " outside 1.." + std::to_string(kMaxTextureSize));
  }
  if (!(d.physical_size_mm.allFinite() && d.physical_size_mm.minCoeff() > 0)) {
    throw core::Error(dir.string() + ": physical size must be positive, got " + Text(d.physical_size_mm.x()) +
                " x " + Text(d.physical_size_mm.y()) + " mm");
  }
  if (!(std::isfinite(d.d_max_mm) && d.d_max_mm > 0)) {
    throw core::Error(dir.string() + ": d_max must be a positive distance, got " + Text(d.d_max_mm) + " mm");
  }
  for (const core::SamplingSet* set : {&d.view_directions, &d.light_directions}) {
    if (set->size() < 1 || set->size() > kMaxDirections) {
      throw core::Error(dir.string() + ": " + (set == &d.view_directions ? "view" : "light") +
                  " direction set has " + std::to_string(set->size()) + " directions; expected 1.." +
                  std::to_string(kMaxDirections));
    }
  }
}

void ExpectGrid(const fs::path& dir, const MaterialDescription& d, const char* part, int width, int height,
                const core::SamplingSet& views) {
  if (width != d.width || height != d.height) {
    throw core::Error(dir.string() + ": " + part + " is " + std::to_string(width) + "x" + std::to_string(height) +
                " texels, the package " + std::to_string(d.width) + "x" + std::to_string(d.height));
  }
  if (!SameDirections(views, d.view_directions)) {
    throw core::Error(dir.string() + ": " + part + " is sampled on other view directions than the package");
  }
}

void ExpectLights(const fs::path& dir, const MaterialDescription& d, const char* part,
                  const core::SamplingSet& lights) {
  if (!SameDirections(lights, d.light_directions)) {
    throw core::Error(dir.string() + ": " + part + " is sampled on other light directions than the package");
  }
}

void ExpectImageSize(const fs::path& dir, const std::string& what, const core::Image& image, int width, int height,
                     int channels) {
  if (image.width() != width || image.height() != height || image.channels() != channels) {
    throw core::Error(dir.string() + ": " + what + " is " +
                SizeText(image.width(), image.height(), image.channels()) + ", expected " +
                SizeText(width, height, channels));
  }
}

// BTF, factor and ambient values must be finite: a NaN would silently poison
// every reconstruction and render that touches it.
void ExpectFiniteToWrite(const fs::path& dir, const std::string& what, const core::Image& image) {
  const float* v = image.data();
  for (std::size_t i = 0; i < image.size(); ++i) {
    if (!std::isfinite(v[i])) {
      const std::size_t pixel = i / image.channels();
      throw core::Error(dir.string() + ": " + what + " has the non-finite value " + Text(v[i]) + " at x=" +
                  std::to_string(pixel % image.width()) + ", y=" + std::to_string(pixel / image.width()));
    }
  }
}

void ThrowIfOversize(const fs::path& dir, const std::string& problem) {
  if (!problem.empty()) throw core::Error(dir.string() + ": " + problem);
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
  j["format"] = kFormat;
  j["version"] = kVersion;
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
      nlohmann::ordered_json factored = {{"layout", ToString(f.layout)},
                                         {"color", ToString(f.color)},
                                         {"rank", f.rank},
                                         {"singular_values", kSingularValues},
                                         {"row_files", kRowFactorFiles},
                                         {"column_file", kColumnFactorFile}};
      if (f.color == core::BtfFactorColor::kYCbCr) factored["rgb_to_factored"] = MatrixJson(f.rgb_to_factored);
      btf["factored"] = factored;
    }
    j["btf"] = btf;
  }
  if (m.ambient) j["ambient"] = {{"file", kAmbientFile}};
  if (m.error_report) j["error_report"] = {{"file", kErrorReportFile}};
  if (m.calibration) j["calibration"] = {{"file", kCalibrationFile}};
  return j;
}

// ---------------------------------------------------------------------------
// Reading the manifest

int ReadTexelCount(const core::JsonFieldReader& r, const std::string& key, const nlohmann::json& value) {
  const std::string expected = "expected an integer in [1, " + std::to_string(kMaxTextureSize) + "]";
  if (!value.is_number_integer()) r.Fail(key, expected + ", got " + value.dump());
  const double x = value.get<double>();  // exact for every integer in range; out-of-range ones stay out
  if (x < 1 || x > kMaxTextureSize) r.Fail(key, expected + ", got " + value.dump());
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
  if (!(value > 0)) r.Fail(key, "expected a positive number, got " + Text(value));
  return value;
}

core::SamplingSet ReadDirections(const core::JsonFieldReader& r, const char* key) {
  core::SamplingSet set = core::ReadSamplingSet(r.Object(key));
  if (set.size() < 1 || set.size() > kMaxDirections) {
    r.Fail(key, "expected 1 to " + std::to_string(kMaxDirections) + " directions, got " +
                    std::to_string(set.size()));
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
  part.forms.float32 = mdf.Has("float32");
  part.forms.uint8 = mdf.Has("uint8");
  if (!part.forms.float32 && !part.forms.uint8)
    mdf.Fail("", "expected a \"float32\" and/or a \"uint8\" form");
  if (part.forms.float32) mdf.Object("float32").Choice("file", {kMdfFloatFile});
  if (part.forms.uint8) {
    const core::JsonFieldReader u = mdf.Object("uint8");
    u.Choice("file", {kMdfUint8File});
    part.scale_mm = ReadPositive(u, "scale_mm", u.Number("scale_mm"));
    u.Integer("max_distance_code", core::QuantizedMdf::kMaxDistanceCode, core::QuantizedMdf::kMaxDistanceCode);
    u.Integer("no_hit_code", core::QuantizedMdf::kNoHitCode, core::QuantizedMdf::kNoHitCode);
    u.Integer("unknown_code", core::QuantizedMdf::kUnknownCode, core::QuantizedMdf::kUnknownCode);
  }
  part.confidence = mdf.Has("confidence");
  if (part.confidence) mdf.Object("confidence").Choice("file", {kMdfConfidenceFile});
  return part;
}

MaterialManifest::FactoredBtfPart ReadFactoredPart(const core::JsonFieldReader& f, const MaterialDescription& d) {
  MaterialManifest::FactoredBtfPart part;
  part.layout = f.Choice("layout", {"paper", "per_texel"}) == "paper" ? core::BtfFactorLayout::kPaper
                                                                      : core::BtfFactorLayout::kPerTexel;
  part.color = f.Choice("color", {"rgb", "ycbcr"}) == "rgb" ? core::BtfFactorColor::kRgb : core::BtfFactorColor::kYCbCr;
  const long long columns =
      part.layout == core::BtfFactorLayout::kPaper
          ? d.view_directions.size()
          : static_cast<long long>(d.view_directions.size()) * d.light_directions.size();
  part.rank = static_cast<int>(f.Integer("rank", 1, std::min<long long>(core::kMaxBtfRank, columns)));
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

// Index of the first value outside [0, 1] (NaN included), or size() if none.
std::size_t FirstOutsideUnitInterval(const core::Image& image) {
  const float* values = image.data();
  for (std::size_t i = 0; i < image.size(); ++i) {
    if (!(values[i] >= 0.0f && values[i] <= 1.0f)) return i;
  }
  return image.size();
}

void ExpectFile(const core::JsonFieldReader& r, const std::string& key, const fs::path& dir, const fs::path& name) {
  std::error_code ec;
  if (!fs::is_regular_file(dir / name, ec)) {
    r.Fail(key, "the package has no file " + name.string() + " (" + (dir / name).string() + ")");
  }
}

void ExpectFiles(const core::JsonFieldReader& root, const MaterialManifest& m, const fs::path& dir) {
  if (m.mdf) {
    if (m.mdf->forms.float32) ExpectFile(root, "mdf.float32.file", dir, kMdfFloatFile);
    if (m.mdf->forms.uint8) ExpectFile(root, "mdf.uint8.file", dir, kMdfUint8File);
    if (m.mdf->confidence) ExpectFile(root, "mdf.confidence.file", dir, kMdfConfidenceFile);
  }
  if (m.full_btf) {
    for (int v = 0; v < m.description.view_directions.size(); ++v) {
      ExpectFile(root, "btf.full.files", dir, FullBtfViewFile(v));
    }
  }
  if (m.factored_btf) {
    for (int k = 0; k < m.factored_btf->rank; ++k) {
      ExpectFile(root, "btf.factored.row_files", dir, BtfRowFactorFile(k));
    }
    ExpectFile(root, "btf.factored.column_file", dir, kColumnFactorFile);
  }
  if (m.ambient) ExpectFile(root, "ambient.file", dir, kAmbientFile);
  if (m.error_report) ExpectFile(root, "error_report.file", dir, kErrorReportFile);
  if (m.calibration) ExpectFile(root, "calibration.file", dir, kCalibrationFile);
}

// ---------------------------------------------------------------------------
// Reading the parts

fs::path ManifestPath(const fs::path& dir) { return dir / kManifestFile; }

// ReadJsonFile turns syntax errors into FormatError; nlohmann reports some
// valid-syntax problems (a number literal beyond double, "1e999") with other
// exception types, which must not escape as anything but a FormatError.
[[noreturn]] void ThrowMissingPart(const fs::path& dir, const char* field, const char* what) {
  throw core::FormatError(ManifestPath(dir), field, std::string("this package has no ") + what);
}

// Reads an image of a part, rejecting another pixel type, size or channel
// count before any pixel is allocated.
core::Image ReadPartImage(const fs::path& file, core::PixelEncoding encoding, int width, int height, int channels) {
  const core::ImageHeader header = core::ReadImageHeader(file);
  if (header.encoding != encoding) {
    throw core::FormatError(file, "pixel type",
                      std::string("expected ") + ToString(encoding) + ", got " + ToString(header.encoding));
  }
  core::ImageReadOptions options;
  options.expected_width = width;
  options.expected_height = height;
  options.expected_channels = channels;
  options.max_values = static_cast<std::size_t>(width) * height * channels;
  return core::ReadImage(file, options);
}

void ExpectFiniteInFile(const fs::path& file, const core::Image& image) {
  const float* v = image.data();
  for (std::size_t i = 0; i < image.size(); ++i) {
    if (!std::isfinite(v[i])) {
      const std::size_t pixel = i / image.channels();
      throw core::FormatError(file, "pixels",
                        "value " + Text(v[i]) + " at x=" + std::to_string(pixel % image.width()) +
                            ", y=" + std::to_string(pixel / image.width()) + "; expected a finite number");
    }
  }
}

}  // namespace

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

// ---------------------------------------------------------------------------
// MaterialPackageWriter

MaterialPackageWriter::MaterialPackageWriter(const fs::path& dir, MaterialDescription description,
                                             bool replace)
    : dir_(dir), folder_(dir, replace) {
  CheckDescription(dir_, description);
  if (description.provenance.software_version.empty()) description.provenance.software_version = core::Version();
  if (description.provenance.created_utc.empty()) description.provenance.created_utc = CurrentUtcTime();
  manifest_.description = std::move(description);
}

void MaterialPackageWriter::ExpectOpen() const {
  if (committed_) throw core::Error(dir_.string() + ": the package was already committed");
}

void MaterialPackageWriter::WriteMdf(const core::Mdf& mdf, MdfForms forms) {
  ExpectOpen();
  const MaterialDescription& d = manifest_.description;
  if (manifest_.mdf) throw core::Error(dir_.string() + ": the MDF was already written");
  if (!forms.float32 && !forms.uint8) throw core::Error(dir_.string() + ": no MDF form chosen (float32, uint8)");
  ExpectGrid(dir_, d, "MDF", mdf.width, mdf.height, mdf.views);
  ThrowIfOversize(dir_, OversizeProblem(d, "MDF", false, 1));
  ExpectImageSize(dir_, "MDF", mdf.distance_mm, d.width, PackedHeight(d, d.view_directions), 1);
  const float* values = mdf.distance_mm.data();
  for (std::size_t i = 0; i < mdf.distance_mm.size(); ++i) {
    if (!core::IsValidMdfValue(values[i])) {
      throw core::Error(dir_.string() + ": MDF value " + Text(values[i]) + " at index " + std::to_string(i) +
                  " is neither a distance >= 0, no hit (+inf) nor unknown (NaN)");
    }
  }
  MaterialManifest::MdfPart part;
  part.forms = forms;
  if (forms.float32)
    core::WriteImage(folder_.temp_path() / kMdfFloatFile, mdf.distance_mm, core::PixelEncoding::kFloat32);
  if (forms.uint8) {
    const core::QuantizedMdf q = core::QuantizeMdf(mdf, d.d_max_mm);
    // The uint8 encoding maps [0, 1] to codes 0..255, so code c is c / 255.
    core::Image codes(mdf.distance_mm.width(), mdf.distance_mm.height(), 1);
    for (std::size_t i = 0; i < q.codes.size(); ++i) codes.data()[i] = q.codes[i] / 255.0f;
    core::WriteImage(folder_.temp_path() / kMdfUint8File, codes, core::PixelEncoding::kUInt8);
    part.scale_mm = q.scale_mm;
  }
  manifest_.mdf = part;
}

void MaterialPackageWriter::WriteMdfConfidence(const core::Image& confidence) {
  ExpectOpen();
  const MaterialDescription& d = manifest_.description;
  if (!manifest_.mdf) throw core::Error(dir_.string() + ": the MDF confidence needs the MDF written first");
  if (manifest_.mdf->confidence) throw core::Error(dir_.string() + ": the MDF confidence was already written");
  ExpectImageSize(dir_, "MDF confidence", confidence, d.width, PackedHeight(d, d.view_directions), 1);
  if (const std::size_t i = FirstOutsideUnitInterval(confidence); i < confidence.size()) {
    throw core::Error(dir_.string() + ": MDF confidence " + Text(confidence.data()[i]) + " at index " + std::to_string(i) +
                " is outside [0, 1]");
  }
  core::WriteImage(folder_.temp_path() / kMdfConfidenceFile, confidence, core::PixelEncoding::kFloat32);
  manifest_.mdf->confidence = true;
}

void MaterialPackageWriter::WriteFullBtfView(int view, const core::Image& values) {
  ExpectOpen();
  const MaterialDescription& d = manifest_.description;
  const int views = d.view_directions.size();
  if (view < 0 || view >= views) {
    throw core::Error(dir_.string() + ": full BTF view " + std::to_string(view) + " outside 0.." +
                std::to_string(views - 1));
  }
  ThrowIfOversize(dir_, OversizeProblem(d, "full BTF", true, 3));
  const std::string what = "full BTF view " + std::to_string(view);
  ExpectImageSize(dir_, what, values, d.width, PackedHeight(d, d.light_directions), 3);
  ExpectFiniteToWrite(dir_, what, values);
  if (full_btf_views_written_.empty()) full_btf_views_written_.assign(views, false);
  if (full_btf_views_written_[view]) throw core::Error(dir_.string() + ": " + what + " was already written");
  fs::create_directories(folder_.temp_path() / "btf");
  core::WriteImage(folder_.temp_path() / FullBtfViewFile(view), values, core::PixelEncoding::kFloat32);
  full_btf_views_written_[view] = true;
}

std::unique_ptr<core::FullBtfReader> MaterialPackageWriter::ReadBackFullBtf() const {
  ExpectOpen();
  const int views = manifest_.description.view_directions.size();
  const auto missing = std::find(full_btf_views_written_.begin(), full_btf_views_written_.end(), false);
  if (full_btf_views_written_.empty() || missing != full_btf_views_written_.end()) {
    const int first = full_btf_views_written_.empty() ? 0 : static_cast<int>(missing - full_btf_views_written_.begin());
    throw core::Error(dir_.string() + ": full BTF view " + std::to_string(first) + " of " + std::to_string(views) +
                " is not written yet; the BTF cannot be read back");
  }
  return std::make_unique<PackageFullBtfReader>(folder_.temp_path(), manifest_.description);
}

void MaterialPackageWriter::WriteFactoredBtf(const core::FactoredBtf& btf) {
  ExpectOpen();
  const MaterialDescription& d = manifest_.description;
  if (manifest_.factored_btf) throw core::Error(dir_.string() + ": the factored BTF was already written");
  ExpectGrid(dir_, d, "factored BTF", btf.width, btf.height, btf.views);
  ExpectLights(dir_, d, "factored BTF", btf.lights);
  ThrowIfOversize(dir_, OversizeProblem(d, "factored BTF", true, 3));
  try {
    btf.CheckShape();
  } catch (const core::Error& e) {
    throw core::Error(dir_.string() + ": " + e.what());
  }
  fs::create_directories(folder_.temp_path() / "btf");
  for (int k = 0; k < btf.rank(); ++k) {
    ExpectFiniteToWrite(dir_, "row factor " + std::to_string(k), btf.rows[k]);
    core::WriteImage(folder_.temp_path() / BtfRowFactorFile(k), btf.rows[k], core::PixelEncoding::kFloat32);
  }
  ExpectFiniteToWrite(dir_, "column factors", btf.columns);
  core::WriteImage(folder_.temp_path() / kColumnFactorFile, btf.columns, core::PixelEncoding::kFloat32);
  MaterialManifest::FactoredBtfPart part;
  part.layout = btf.layout;
  part.color = btf.color;
  part.rgb_to_factored =
      btf.color == core::BtfFactorColor::kYCbCr ? btf.rgb_to_factored : Eigen::Matrix3d::Identity();
  part.rank = btf.rank();
  manifest_.factored_btf = part;
}

void MaterialPackageWriter::WriteAmbientTerm(const AmbientTerm& ambient) {
  ExpectOpen();
  const MaterialDescription& d = manifest_.description;
  if (manifest_.ambient) throw core::Error(dir_.string() + ": the ambient term was already written");
  ExpectGrid(dir_, d, "ambient term", ambient.width, ambient.height, ambient.views);
  ThrowIfOversize(dir_, OversizeProblem(d, "ambient term", false, 3));
  ExpectImageSize(dir_, "ambient term", ambient.values, d.width, PackedHeight(d, d.view_directions), 3);
  ExpectFiniteToWrite(dir_, "ambient term", ambient.values);
  core::WriteImage(folder_.temp_path() / kAmbientFile, ambient.values, core::PixelEncoding::kFloat32);
  manifest_.ambient = true;
}

void MaterialPackageWriter::WriteErrorReport(const nlohmann::json& report) {
  ExpectOpen();
  if (manifest_.error_report) throw core::Error(dir_.string() + ": the error report was already written");
  if (!report.is_object()) throw core::Error(dir_.string() + ": the error report must be a JSON object");
  core::WriteJsonFileAtomically(folder_.temp_path() / kErrorReportFile, report);
  manifest_.error_report = true;
}

void MaterialPackageWriter::WriteCalibration(const Calibration& calibration) {
  ExpectOpen();
  if (manifest_.calibration) throw core::Error(dir_.string() + ": the calibration was already written");
  mesocap::formats::WriteCalibration(folder_.temp_path() / kCalibrationFile, calibration);
  manifest_.calibration = true;
}

MaterialManifest MaterialPackageWriter::Commit() {
  ExpectOpen();
  for (std::size_t v = 0; v < full_btf_views_written_.size(); ++v) {
    if (!full_btf_views_written_[v]) {
      throw core::Error(dir_.string() + ": full BTF view " + std::to_string(v) + " of " +
                  std::to_string(full_btf_views_written_.size()) + " was never written");
    }
  }
  manifest_.full_btf = !full_btf_views_written_.empty();
  core::WriteTextFileAtomically(folder_.temp_path() / kManifestFile, ManifestJson(manifest_).dump(2) + "\n");
  // Never publish a package this build cannot read back.
  MaterialManifest written = ReadMaterialManifest(folder_.temp_path());
  folder_.Commit();
  committed_ = true;
  return written;
}

void WriteMaterialPackage(const fs::path& dir, const MaterialPackage& package, bool replace) {
  MaterialPackageWriter writer(dir, package.description, replace);
  const MaterialDescription& d = writer.description();
  if (package.mdf) writer.WriteMdf(*package.mdf, package.mdf_forms);
  if (package.full_btf) {
    const core::FullBtf& btf = *package.full_btf;
    ExpectGrid(dir, d, "full BTF", btf.width, btf.height, btf.views);
    ExpectLights(dir, d, "full BTF", btf.lights);
    if (static_cast<int>(btf.view_images.size()) != d.view_directions.size()) {
      throw core::Error(dir.string() + ": full BTF has " + std::to_string(btf.view_images.size()) +
                  " view images for " + std::to_string(d.view_directions.size()) + " view directions");
    }
    for (int v = 0; v < d.view_directions.size(); ++v) writer.WriteFullBtfView(v, btf.view_images[v]);
  }
  if (package.factored_btf) writer.WriteFactoredBtf(*package.factored_btf);
  if (package.ambient) writer.WriteAmbientTerm(*package.ambient);
  if (package.error_report) writer.WriteErrorReport(*package.error_report);
  writer.Commit();
}

// ---------------------------------------------------------------------------
// Reading

MaterialManifest ReadMaterialManifest(const fs::path& dir) {
  const fs::path file = ManifestPath(dir);
  const nlohmann::json doc = core::ReadJsonFile(file, kMaxJsonBytes);
  const core::JsonFieldReader root(doc, file);
  root.ExpectFormat(kFormat, kVersion);
  const core::JsonFieldReader units = root.Object("units");
  units.Choice("length", {"mm"});
  units.Choice("angle", {"deg"});

  MaterialManifest m;
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
  d.provenance.software_version = provenance.String("software_version");
  d.provenance.created_utc = provenance.String("created_utc");
  d.provenance.source = provenance.String("source");

  if (root.Has("mdf")) {
    m.mdf = ReadMdfPart(root.Object("mdf"));
    if (auto problem = OversizeProblem(d, "MDF", false, 1); !problem.empty()) root.Fail("mdf", problem);
  }
  if (root.Has("btf")) {
    const core::JsonFieldReader btf = root.Object("btf");
    btf.Choice("values", {kBtfValues});
    m.full_btf = btf.Has("full");
    if (m.full_btf) btf.Object("full").Choice("files", {kFullBtfFiles});
    if (btf.Has("factored")) m.factored_btf = ReadFactoredPart(btf.Object("factored"), d);
    if (!m.full_btf && !m.factored_btf) btf.Fail("", "expected a \"full\" and/or a \"factored\" form");
    if (auto problem = OversizeProblem(d, "BTF", true, 3); !problem.empty()) root.Fail("btf", problem);
  }
  if (root.Has("ambient")) {
    root.Object("ambient").Choice("file", {kAmbientFile});
    m.ambient = true;
    if (auto problem = OversizeProblem(d, "ambient term", false, 3); !problem.empty())
      root.Fail("ambient", problem);
  }
  if (root.Has("error_report")) {
    root.Object("error_report").Choice("file", {kErrorReportFile});
    m.error_report = true;
  }
  if (root.Has("calibration")) {
    root.Object("calibration").Choice("file", {kCalibrationFile});
    m.calibration = true;
  }
  ExpectFiles(root, m, dir);
  return m;
}

core::Mdf ReadMdf(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.mdf) ThrowMissingPart(dir, "mdf", "MDF");
  if (!manifest.mdf->forms.float32) return core::DequantizeMdf(ReadQuantizedMdf(dir, manifest));
  const MaterialDescription& d = manifest.description;
  const fs::path file = dir / kMdfFloatFile;
  core::Mdf mdf;
  mdf.width = d.width;
  mdf.height = d.height;
  mdf.views = d.view_directions;
  mdf.distance_mm =
      ReadPartImage(file, core::PixelEncoding::kFloat32, d.width, PackedHeight(d, d.view_directions), 1);
  const float* values = mdf.distance_mm.data();
  for (std::size_t i = 0; i < mdf.distance_mm.size(); ++i) {
    if (!core::IsValidMdfValue(values[i])) {
      const std::size_t row = i / d.width;
      throw core::FormatError(file, "pixels",
                        "value " + Text(values[i]) + " at view " + std::to_string(row / d.height) +
                            ", texel (" + std::to_string(i % d.width) + ", " +
                            std::to_string(row % d.height) +
                            "); expected a distance >= 0, +inf (no hit) or NaN (unknown)");
    }
  }
  return mdf;
}

core::Image ReadMdfConfidence(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.mdf || !manifest.mdf->confidence) ThrowMissingPart(dir, "mdf.confidence", "MDF confidence");
  const MaterialDescription& d = manifest.description;
  const fs::path file = dir / kMdfConfidenceFile;
  core::Image confidence = ReadPartImage(file, core::PixelEncoding::kFloat32, d.width, PackedHeight(d, d.view_directions), 1);
  if (const std::size_t i = FirstOutsideUnitInterval(confidence); i < confidence.size()) {
    const std::size_t row = i / d.width;
    throw core::FormatError(file, "pixels",
                      "value " + Text(confidence.data()[i]) + " at view " + std::to_string(row / d.height) +
                          ", texel (" + std::to_string(i % d.width) + ", " + std::to_string(row % d.height) +
                          "); expected a confidence in [0, 1]");
  }
  return confidence;
}

core::QuantizedMdf ReadQuantizedMdf(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.mdf || !manifest.mdf->forms.uint8) ThrowMissingPart(dir, "mdf.uint8", "8-bit MDF");
  const MaterialDescription& d = manifest.description;
  const core::Image image = ReadPartImage(dir / kMdfUint8File, core::PixelEncoding::kUInt8, d.width,
                                    PackedHeight(d, d.view_directions), 1);
  core::QuantizedMdf q;
  q.width = d.width;
  q.height = d.height;
  q.views = d.view_directions;
  q.scale_mm = manifest.mdf->scale_mm;
  q.codes.resize(image.size());
  // Read back as c / 255; every code 0..255 is meaningful.
  for (std::size_t i = 0; i < q.codes.size(); ++i) {
    q.codes[i] = static_cast<std::uint8_t>(std::lround(std::clamp(image.data()[i], 0.0f, 1.0f) * 255.0f));
  }
  return q;
}

core::Image ReadFullBtfView(const fs::path& dir, const MaterialManifest& manifest, int view) {
  if (!manifest.full_btf) ThrowMissingPart(dir, "btf.full", "full BTF");
  const MaterialDescription& d = manifest.description;
  if (view < 0 || view >= d.view_directions.size()) {
    throw core::Error(dir.string() + ": full BTF view " + std::to_string(view) + " outside 0.." +
                std::to_string(d.view_directions.size() - 1));
  }
  const fs::path file = dir / FullBtfViewFile(view);
  core::Image image = ReadPartImage(file, core::PixelEncoding::kFloat32, d.width, PackedHeight(d, d.light_directions), 3);
  ExpectFiniteInFile(file, image);
  return image;
}

core::FullBtf ReadFullBtf(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.full_btf) ThrowMissingPart(dir, "btf.full", "full BTF");
  const MaterialDescription& d = manifest.description;
  core::FullBtf btf;
  btf.width = d.width;
  btf.height = d.height;
  btf.views = d.view_directions;
  btf.lights = d.light_directions;
  btf.view_images.reserve(d.view_directions.size());
  for (int v = 0; v < d.view_directions.size(); ++v)
    btf.view_images.push_back(ReadFullBtfView(dir, manifest, v));
  return btf;
}

PackageFullBtfReader::PackageFullBtfReader(const fs::path& dir, const MaterialManifest& manifest)
    : PackageFullBtfReader(dir, manifest.description) {
  if (!manifest.full_btf) ThrowMissingPart(dir, "btf.full", "full BTF");
}

PackageFullBtfReader::PackageFullBtfReader(const fs::path& dir, const MaterialDescription& description)
    : core::FullBtfReader(description.width, description.height, description.view_directions,
                    description.light_directions),
      dir_(dir),
      open_(description.view_directions.size()),
      view_mutex_(description.view_directions.size()) {}

PackageFullBtfReader::~PackageFullBtfReader() = default;

std::string PackageFullBtfReader::Source(int view) const { return (dir_ / FullBtfViewFile(view)).string(); }

std::unique_ptr<core::ImageRowReader> PackageFullBtfReader::Open(int view) const {
  const fs::path file = dir_ / FullBtfViewFile(view);
  core::ImageReadOptions expected;
  expected.expected_width = width();
  expected.expected_height = height() * light_count();
  expected.expected_channels = 3;
  auto reader = std::make_unique<core::ImageRowReader>(file, expected);
  if (reader->header().encoding != core::PixelEncoding::kFloat32) {
    throw core::FormatError(file, "pixel type", std::string("expected float32, got ") + ToString(reader->header().encoding));
  }
  return reader;
}

void PackageFullBtfReader::ReadRowsFromSource(int view, int first_row, int rows, float* out) {
  if (view_count() > kMaxOpenViews) {
    Open(view)->Read(first_row, rows, out);
    return;
  }
  std::lock_guard lock(view_mutex_[view]);
  if (!open_[view]) open_[view] = Open(view);
  open_[view]->Read(first_row, rows, out);
}

core::FactoredBtf ReadFactoredBtf(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.factored_btf) ThrowMissingPart(dir, "btf.factored", "factored BTF");
  const MaterialDescription& d = manifest.description;
  const auto& part = *manifest.factored_btf;
  core::FactoredBtf btf;
  btf.width = d.width;
  btf.height = d.height;
  btf.views = d.view_directions;
  btf.lights = d.light_directions;
  btf.layout = part.layout;
  btf.color = part.color;
  btf.rgb_to_factored = part.rgb_to_factored;
  for (int k = 0; k < part.rank; ++k) {
    const fs::path file = dir / BtfRowFactorFile(k);
    btf.rows.push_back(ReadPartImage(file, core::PixelEncoding::kFloat32, d.width, btf.row_image_height(), 3));
    ExpectFiniteInFile(file, btf.rows.back());
  }
  const fs::path columns = dir / kColumnFactorFile;
  btf.columns = ReadPartImage(columns, core::PixelEncoding::kFloat32, btf.column_count(), part.rank, 3);
  ExpectFiniteInFile(columns, btf.columns);
  return btf;
}

AmbientTerm ReadAmbientTerm(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.ambient) ThrowMissingPart(dir, "ambient", "ambient term");
  const MaterialDescription& d = manifest.description;
  const fs::path file = dir / kAmbientFile;
  AmbientTerm ambient;
  ambient.width = d.width;
  ambient.height = d.height;
  ambient.views = d.view_directions;
  ambient.values =
      ReadPartImage(file, core::PixelEncoding::kFloat32, d.width, PackedHeight(d, d.view_directions), 3);
  ExpectFiniteInFile(file, ambient.values);
  return ambient;
}

nlohmann::json ReadErrorReport(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.error_report) ThrowMissingPart(dir, "error_report", "error report");
  const fs::path file = dir / kErrorReportFile;
  nlohmann::json report = core::ReadJsonFile(file, kMaxJsonBytes);
  if (!report.is_object()) throw core::FormatError(file, "", "expected a JSON object");
  return report;
}

Calibration ReadPackageCalibration(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.calibration) ThrowMissingPart(dir, "calibration", "calibration");
  return ReadCalibration(dir / kCalibrationFile);
}

MaterialPackage ReadMaterialPackage(const fs::path& dir) {
  const MaterialManifest manifest = ReadMaterialManifest(dir);
  MaterialPackage package;
  package.description = manifest.description;
  if (manifest.mdf) {
    package.mdf = ReadMdf(dir, manifest);
    package.mdf_forms = manifest.mdf->forms;
  }
  if (manifest.full_btf) package.full_btf = ReadFullBtf(dir, manifest);
  if (manifest.factored_btf) package.factored_btf = ReadFactoredBtf(dir, manifest);
  if (manifest.ambient) package.ambient = ReadAmbientTerm(dir, manifest);
  if (manifest.error_report) package.error_report = ReadErrorReport(dir, manifest);
  return package;
}

}  // namespace mesocap::formats
