#include "formats/material_package_writer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>

#include "core/error.h"
#include "core/file_checksum.h"
#include "core/image_io.h"
#include "core/version.h"
#include "formats/material_package_layout.h"
#include "formats/package_full_btf_reader.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
namespace {

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

// A part's directions are the package's when they agree to this (unit
// vectors): the same set computed twice, or read back from the manifest.
constexpr double kSameDirection = 1e-9;

void CheckDescription(const fs::path& dir, const MaterialDescription& d) {
  if (const core::CheckResult problem = core::CheckImageSize(d.width, d.height, "texture size"); !problem.empty()) {
    throw core::Error(dir.string() + ": " + problem);
  }
  if (!(d.physical_size_mm.allFinite() && d.physical_size_mm.minCoeff() > 0)) {
    throw core::Error(dir.string() + ": physical size must be positive, got " + NumberText(d.physical_size_mm.x()) +
                      " x " + NumberText(d.physical_size_mm.y()) + " mm");
  }
  if (!(std::isfinite(d.d_max_mm) && d.d_max_mm > 0)) {
    throw core::Error(dir.string() + ": d_max must be a positive distance, got " + NumberText(d.d_max_mm) + " mm");
  }
  for (const core::SamplingSet* set : {&d.view_directions, &d.light_directions}) {
    if (set->size() < 1 || set->size() > kMaxDirections) {
      throw core::Error(dir.string() + ": " + (set == &d.view_directions ? "view" : "light") + " direction set has " +
                        std::to_string(set->size()) + " directions; expected 1.." + std::to_string(kMaxDirections));
    }
  }
}

void ExpectGrid(const fs::path& dir, const MaterialDescription& d, const char* part, int width, int height,
                const core::SamplingSet& views) {
  if (width != d.width || height != d.height) {
    throw core::Error(dir.string() + ": " + part + " is " + std::to_string(width) + "x" + std::to_string(height) +
                      " texels, the package " + std::to_string(d.width) + "x" + std::to_string(d.height));
  }
  if (!views.SameDirectionsAs(d.view_directions, kSameDirection)) {
    throw core::Error(dir.string() + ": " + part + " is sampled on other view directions than the package");
  }
}

void ExpectLights(const fs::path& dir, const MaterialDescription& d, const char* part,
                  const core::SamplingSet& lights) {
  if (!lights.SameDirectionsAs(d.light_directions, kSameDirection)) {
    throw core::Error(dir.string() + ": " + part + " is sampled on other light directions than the package");
  }
}

void ExpectImageSize(const fs::path& dir, const std::string& what, const core::Image& image, int width, int height,
                     int channels) {
  if (image.width() != width || image.height() != height || image.channels() != channels) {
    throw core::Error(dir.string() + ": " + what + " is " + SizeText(image.width(), image.height(), image.channels()) +
                      ", expected " + SizeText(width, height, channels));
  }
}

// BTF, factor and ambient values must be finite: a NaN would silently poison
// every reconstruction and render that touches it.
void ExpectFiniteToWrite(const fs::path& dir, const std::string& what, const core::Image& image) {
  const float* v = image.data();
  for (std::size_t i = 0; i < image.size(); ++i) {
    if (!std::isfinite(v[i])) {
      const std::size_t pixel = i / image.channels();
      throw core::Error(dir.string() + ": " + what + " has the non-finite value " + NumberText(v[i]) + " at x=" +
                        std::to_string(pixel % image.width()) + ", y=" + std::to_string(pixel / image.width()));
    }
  }
}

void ThrowIfOversize(const fs::path& dir, const std::string& problem) {
  if (!problem.empty()) throw core::Error(dir.string() + ": " + problem);
}

}  // namespace

// ---------------------------------------------------------------------------
// MaterialPackageWriter

MaterialPackageWriter::MaterialPackageWriter(const fs::path& dir, MaterialDescription description, bool replace,
                                             std::vector<fs::path> inputs)
    : dir_(dir), folder_(dir, PackageReplacement(replace, std::move(inputs))) {
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
      throw core::Error(dir_.string() + ": MDF value " + NumberText(values[i]) + " at index " + std::to_string(i) +
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
    throw core::Error(dir_.string() + ": MDF confidence " + NumberText(confidence.data()[i]) + " at index " +
                      std::to_string(i) + " is outside [0, 1]");
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
  if (btf.layout == core::BtfFactorLayout::kClustered) {
    core::Image ids(btf.width, btf.height, 1);
    for (std::size_t i = 0; i < btf.texel_clusters.size(); ++i)
      ids.data()[i] = static_cast<float>(btf.texel_clusters[i]);
    core::WriteImage(folder_.temp_path() / kClusterFile, ids, core::PixelEncoding::kFloat32);
  }
  MaterialManifest::FactoredBtfPart part;
  part.layout = btf.layout;
  part.color = btf.color;
  part.rgb_to_factored = btf.color == core::BtfFactorColor::kYCbCr ? btf.rgb_to_factored : Eigen::Matrix3d::Identity();
  part.rank = btf.rank();
  part.clusters = btf.layout == core::BtfFactorLayout::kClustered ? btf.cluster_count : 1;
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
  manifest_.checksums.clear();
  for (const std::string& name : PackageDataFiles(manifest_)) {
    manifest_.checksums.emplace(name, core::ComputeFileChecksum(folder_.temp_path() / name));
  }
  WriteMaterialManifest(folder_.temp_path(), manifest_);
  // Never publish a package this build cannot read back.
  MaterialManifest written = ReadMaterialManifest(folder_.temp_path());
  folder_.Commit();
  committed_ = true;
  return written;
}

core::OutputReplacement PackageReplacement(bool replace, std::vector<fs::path> inputs) {
  return {replace, "a material package", IsMaterialPackageFolder, std::move(inputs)};
}

void WriteMaterialPackage(const fs::path& dir, const MaterialPackage& package, bool replace,
                          std::vector<fs::path> inputs) {
  MaterialPackageWriter writer(dir, package.description, replace, std::move(inputs));
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

}  // namespace mesocap::formats
