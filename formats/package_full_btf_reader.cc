#include "formats/package_full_btf_reader.h"

#include "core/error.h"
#include "formats/material_package_layout.h"

namespace mesocap::formats {
namespace fs = std::filesystem;

PackageFullBtfReader::PackageFullBtfReader(const fs::path& dir, const MaterialManifest& manifest)
    : PackageFullBtfReader(dir, manifest.description) {
  if (!manifest.full_btf) ThrowMissingPart(dir, "btf.full", "full BTF");
  checks_.checksums = manifest.checksums;
}

PackageFullBtfReader::PackageFullBtfReader(const fs::path& dir, const MaterialDescription& description)
    : core::FullBtfReader(description.width, description.height, description.view_directions,
                          description.light_directions),
      dir_(dir),
      checked_(description.view_directions.size(), 0),
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
    throw core::FormatError(file, "pixel type",
                            std::string("expected float32, got ") + ToString(reader->header().encoding));
  }
  return reader;
}

void PackageFullBtfReader::ReadRowsFromSource(int view, int first_row, int rows, float* out) {
  std::unique_lock lock(view_mutex_[view]);
  if (!checked_[view]) {
    ExpectPackageFileIntact(dir_, checks_, FullBtfViewFile(view).generic_string());
    checked_[view] = 1;
  }
  if (view_count() > kMaxOpenViews) {
    lock.unlock();
    Open(view)->Read(first_row, rows, out);
    return;
  }
  if (!open_[view]) open_[view] = Open(view);
  open_[view]->Read(first_row, rows, out);
}

}  // namespace mesocap::formats
