// Tiny valid instances of the formats, shared by the fuzzers (the valid
// folder a folder reader's fuzz input lands in, built once at start-up) and
// make_seed_corpus (the seeds). Each is a few KB on disk, so that one read
// takes well under a millisecond and libFuzzer runs many per second.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/image.h"
#include "formats/capture_session.h"
#include "formats/material_package.h"
#include "formats/sweep_analysis.h"

namespace mesocap::fuzz {

// 4 x 3 texels, 3 views, 2 lights; every part: both MDF forms, the full and
// the factored BTF, the ambient term, an error report.
formats::MaterialPackage TinyMaterialPackage();

// The files of a folder (relative paths, sorted), for fuzzers that replace
// one of them: the fuzzer and the seed generator number them alike.
std::vector<std::filesystem::path> FilesOf(const std::filesystem::path& dir);

// A session manifest with one step of each kind; the journal fuzzer checks
// journals against its plan.
formats::SessionManifest TinySessionManifest();

// 5 x 4 pixels, 3 frames, one without a plane.
formats::SweepAnalysis TinySweepAnalysis();

// A unit cube with texture coordinates and normals, quads and a fan, in the
// OBJ subset formats/obj_mesh.h reads.
std::string TinyObjText();

// A small RGB image with values in [0, 1].
core::Image TinyImage(int width, int height, int channels);

}  // namespace mesocap::fuzz
