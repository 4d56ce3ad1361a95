#include "formats/material_package_reader.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "formats/material_package_layout.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
namespace {

// Reads the image `name` of a part: its checksum first (a flipped bit in a
// compressed block can decode without error), then another pixel type, size
// or channel count is refused before any pixel is allocated.
core::Image ReadPartImage(const fs::path& dir, const MaterialManifest& manifest, const std::string& name,
                          core::PixelEncoding encoding, int width, int height, int channels) {
  ExpectPackageFileIntact(dir, manifest, name);
  const fs::path file = dir / name;
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
                              "value " + NumberText(v[i]) + " at x=" + std::to_string(pixel % image.width()) +
                                  ", y=" + std::to_string(pixel / image.width()) + "; expected a finite number");
    }
  }
}

}  // namespace

core::Mdf ReadMdf(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.mdf) ThrowMissingPart(dir, "mdf", "MDF");
  if (!manifest.mdf->forms.float32) return core::DequantizeMdf(ReadQuantizedMdf(dir, manifest));
  const MaterialDescription& d = manifest.description;
  const fs::path file = dir / kMdfFloatFile;
  core::Mdf mdf;
  mdf.width = d.width;
  mdf.height = d.height;
  mdf.views = d.view_directions;
  mdf.distance_mm = ReadPartImage(dir, manifest, kMdfFloatFile, core::PixelEncoding::kFloat32, d.width,
                                  PackedHeight(d, d.view_directions), 1);
  const float* values = mdf.distance_mm.data();
  for (std::size_t i = 0; i < mdf.distance_mm.size(); ++i) {
    if (!core::IsValidMdfValue(values[i])) {
      const std::size_t row = i / d.width;
      throw core::FormatError(file, "pixels",
                              "value " + NumberText(values[i]) + " at view " + std::to_string(row / d.height) +
                                  ", texel (" + std::to_string(i % d.width) + ", " + std::to_string(row % d.height) +
                                  "); expected a distance >= 0, +inf (no hit) or NaN (unknown)");
    }
  }
  return mdf;
}

core::Image ReadMdfConfidence(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.mdf || !manifest.mdf->confidence) ThrowMissingPart(dir, "mdf.confidence", "MDF confidence");
  const MaterialDescription& d = manifest.description;
  const fs::path file = dir / kMdfConfidenceFile;
  core::Image confidence = ReadPartImage(dir, manifest, kMdfConfidenceFile, core::PixelEncoding::kFloat32, d.width,
                                         PackedHeight(d, d.view_directions), 1);
  if (const std::size_t i = FirstOutsideUnitInterval(confidence); i < confidence.size()) {
    const std::size_t row = i / d.width;
    throw core::FormatError(file, "pixels",
                            "value " + NumberText(confidence.data()[i]) + " at view " + std::to_string(row / d.height) +
                                ", texel (" + std::to_string(i % d.width) + ", " + std::to_string(row % d.height) +
                                "); expected a confidence in [0, 1]");
  }
  return confidence;
}

core::QuantizedMdf ReadQuantizedMdf(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.mdf || !manifest.mdf->forms.uint8) ThrowMissingPart(dir, "mdf.uint8", "8-bit MDF");
  const MaterialDescription& d = manifest.description;
  const core::Image image = ReadPartImage(dir, manifest, kMdfUint8File, core::PixelEncoding::kUInt8, d.width,
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
  core::Image image = ReadPartImage(dir, manifest, FullBtfViewFile(view).generic_string(),
                                    core::PixelEncoding::kFloat32, d.width, PackedHeight(d, d.light_directions), 3);
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
  for (int v = 0; v < d.view_directions.size(); ++v) btf.view_images.push_back(ReadFullBtfView(dir, manifest, v));
  return btf;
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
    btf.rows.push_back(ReadPartImage(dir, manifest, BtfRowFactorFile(k).generic_string(), core::PixelEncoding::kFloat32,
                                     d.width, btf.row_image_height(), 3));
    ExpectFiniteInFile(file, btf.rows.back());
  }
  const fs::path columns = dir / kColumnFactorFile;
  const int column_sets = part.layout == core::BtfFactorLayout::kPerView ? d.view_directions.size() : part.clusters;
  btf.columns = ReadPartImage(dir, manifest, kColumnFactorFile, core::PixelEncoding::kFloat32, btf.column_count(),
                              part.rank * column_sets, 3);
  ExpectFiniteInFile(columns, btf.columns);
  if (part.layout == core::BtfFactorLayout::kClustered) {
    btf.cluster_count = part.clusters;
    const core::Image ids =
        ReadPartImage(dir, manifest, kClusterFile, core::PixelEncoding::kFloat32, d.width, d.height, 1);
    btf.texel_clusters.resize(ids.size());
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const float id = ids.data()[i];
      if (!(id >= 0.0f && id < static_cast<float>(part.clusters) && id == std::floor(id))) {
        throw core::FormatError(
            dir / kClusterFile, "texel " + std::to_string(i % d.width) + "," + std::to_string(i / d.width),
            "expected a cluster id in 0.." + std::to_string(part.clusters - 1) + ", got " + std::to_string(id));
      }
      btf.texel_clusters[i] = static_cast<int>(id);
    }
  }
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
  ambient.values = ReadPartImage(dir, manifest, kAmbientFile, core::PixelEncoding::kFloat32, d.width,
                                 PackedHeight(d, d.view_directions), 3);
  ExpectFiniteInFile(file, ambient.values);
  return ambient;
}

nlohmann::json ReadErrorReport(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.error_report) ThrowMissingPart(dir, "error_report", "error report");
  const fs::path file = dir / kErrorReportFile;
  ExpectPackageFileIntact(dir, manifest, kErrorReportFile);
  nlohmann::json report = core::ReadJsonFile(file, kMaxJsonBytes);
  if (!report.is_object()) throw core::FormatError(file, "", "expected a JSON object");
  return report;
}

Calibration ReadPackageCalibration(const fs::path& dir, const MaterialManifest& manifest) {
  if (!manifest.calibration) ThrowMissingPart(dir, "calibration", "calibration");
  ExpectPackageFileIntact(dir, manifest, kCalibrationFile);
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
