// The full BTF of a material package (material_package.h) read from its view
// files a range of rows at a time (core/btf.h: FullBtfReader), so a pass over
// it never holds the whole BTF.
#pragma once

#include <filesystem>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "core/btf.h"
#include "core/image_io.h"
#include "formats/material_manifest.h"

namespace mesocap::formats {

// Keeps each view's file open between reads (up to kMaxOpenViews views; with
// more, each read opens and closes its file); FormatError (naming the file)
// for a view file of another size, channel count or pixel type, a truncated
// one, or one whose checksum differs from the manifest's (checked once per
// view, at its first read).
class PackageFullBtfReader : public core::FullBtfReader {
 public:
  static constexpr int kMaxOpenViews = 256;
  // Throws FormatError when the manifest has no full BTF.
  PackageFullBtfReader(const std::filesystem::path& dir, const MaterialManifest& manifest);
  // The view files under `dir`/btf of a package being written.
  PackageFullBtfReader(const std::filesystem::path& dir, const MaterialDescription& description);
  ~PackageFullBtfReader() override;

 protected:
  std::string Source(int view) const override;
  void ReadRowsFromSource(int view, int first_row, int rows, float* out) override;

 private:
  std::unique_ptr<core::ImageRowReader> Open(int view) const;

  std::filesystem::path dir_;
  MaterialManifest checks_;    // its checksums; none for a package being written (nothing to check yet)
  std::vector<char> checked_;  // per view: its checksum matched; guarded by view_mutex_
  std::vector<std::unique_ptr<core::ImageRowReader>> open_;  // per view; null until first read
  std::vector<std::mutex> view_mutex_;                       // guards open_[view] and its reads
};

}  // namespace mesocap::formats
