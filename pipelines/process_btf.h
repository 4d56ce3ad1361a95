// The BTF job (`mesocap process btf`): the BTF of a capture session (MDF
// paper Sec. 3.1 and 5): every BTF image rectified into texture space,
// divided by its lamp's irradiance, placed on the session's view and light
// sets, factored by SVD; with the ambient term (Sec. 4.2), the calibration
// and the figures of each stage in the error report of a new package.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "btf/btf_compression.h"
#include "core/error.h"

namespace mesocap::pipelines {

struct ProcessBtfOptions {
  std::filesystem::path session;      // capture session folder
  std::filesystem::path calibration;  // calibration file; empty: the one the session names
  std::filesystem::path out;          // material package folder to write
  // A package `process mdf` made of the same sample at the same texture
  // size, whose MDF (and confidence) the new package carries, so that it
  // renders; empty: a package without MDF.
  std::filesystem::path mdf;
  int texture_size = 64;  // texels per side
  // Camera signal (fraction of full scale) per radiance second for every
  // camera; 0: each camera's radiometry from the calibration.
  double gain = 0.0;
  bool full = false;      // also store the full (uncompressed) BTF
  bool resample = false;  // resample captures off the session's sets instead of requiring them within 1 degree
  bool replace = false;   // replace an existing package at `out`
  // Plan steps the session may lack (ids or shell patterns; "*": any), whose
  // images are then left out; empty: the session must be complete.
  std::vector<std::string> allow_incomplete;
  btf::BtfCompressionOptions compression;

  core::CheckResult Check() const;
};

struct ProcessBtfReport {
  int images = 0;  // BTF images assembled
  btf::BtfCompressionReport compression;
};

// Reads the session's manifest, calibration and BTF images once and writes
// the package at `out` atomically; the BTF is streamed through the package
// (or a scratch package beside it without `full`), never whole in memory.
// Throws Error ("process btf: ...") for bad options, a camera without a
// gain, or an existing `out` without `replace`.
ProcessBtfReport RunProcessBtf(const ProcessBtfOptions& options);

}  // namespace mesocap::pipelines
