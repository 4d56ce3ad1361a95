// Writes the fuzzers' seed corpus: for each fuzzer (fuzz/<name>_fuzzer.cc) a
// folder OUT/<name>/ of valid inputs made by mesocap's own writers (the true
// calibration and the shipped rigs of sim/, the material package writer, a
// capture session with its journal, ...), each a few KB. Every seed is read
// back by the reader its fuzzer drives, so a seed the readers refuse fails
// this program (and the ctest test that runs it).
//
// Usage: make_seed_corpus OUT   (OUT is emptied first)
#include <cstdio>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "acquisition/capture_plan.h"
#include "btf/btf_compression.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"
#include "core/sampling_set.h"
#include "formats/calibration.h"
#include "formats/capture_journal.h"
#include "formats/capture_plan_steps.h"
#include "formats/capture_session.h"
#include "formats/frame_sequence.h"
#include "formats/material_package_reader.h"
#include "formats/material_package_writer.h"
#include "formats/obj_mesh.h"
#include "formats/rig_description.h"
#include "formats/sweep_analysis.h"
#include "fuzz/fuzz_input.h"
#include "fuzz/tiny_instances.h"
#include "interop/bonn/bonn_btf_file.h"
#include "interop/bonn/bonn_interop.h"
#include "interop/bonn/bonn_ubo2003.h"
#include "interop/bonn/ubo_sampling_sets.h"
#include "render/render_scene.h"
#include "sim/fault_plan.h"
#include "sim/shipped_rigs.h"
#include "sim/true_calibration.h"

namespace mesocap::fuzz {
namespace {
namespace fs = std::filesystem;

// Where the seeds go, and the scratch folder the writers write into first.
class Corpus {
 public:
  explicit Corpus(fs::path out) : out_(std::move(out)) {
    fs::remove_all(out_);
    fs::create_directories(out_);
  }

  // A seed of fuzzer `fuzzer`; `variant` (>= 0) becomes its first byte.
  void Add(const std::string& fuzzer, const std::string& name, const std::string& bytes, int variant = -1) {
    fs::create_directories(out_ / fuzzer);
    const std::string prefix = variant >= 0 ? std::string(1, static_cast<char>(variant)) : "";
    WriteFileBytes(out_ / fuzzer / name, prefix + bytes);
    ++count_;
  }
  void AddFile(const std::string& fuzzer, const std::string& name, const fs::path& file, int variant = -1) {
    Add(fuzzer, name, ReadFileBytes(file), variant);
  }

  // A fresh folder to write into.
  fs::path Scratch(const std::string& name) const {
    const fs::path dir = ScratchDir() / name;
    fs::remove_all(dir);
    fs::create_directories(dir);
    return dir;
  }
  int count() const { return count_; }

 private:
  fs::path out_;
  int count_ = 0;
};

void AddRigsAndCalibrations(Corpus& corpus) {
  for (const std::string& name : sim::ShippedRigNames()) {
    const formats::RigDescription rig = sim::LoadRig(name);
    const fs::path dir = corpus.Scratch("rig-" + name);
    WriteFileBytes(dir / "rig.json", rig.json.dump(2));
    formats::ReadRigDescription(dir / "rig.json");
    corpus.AddFile("rig_description", name + ".json", dir / "rig.json");

    formats::WriteCalibration(dir / "calibration.json", sim::TrueCalibration(rig));
    formats::ReadCalibration(dir / "calibration.json");
    corpus.AddFile("calibration", name + ".json", dir / "calibration.json");
  }
}

// The tiny rig's session with its whole capture plan, and a journal of the
// steps of fuzz::TinySessionManifest (what the journal fuzzer checks against).
void AddSessions(Corpus& corpus) {
  const formats::RigDescription rig = sim::LoadRig("tiny");
  formats::SessionManifest planned = TinySessionManifest();
  planned.rig = rig.json;
  planned.plan = acquisition::MakeCapturePlan(rig);
  const fs::path session = corpus.Scratch("session") / "tiny";
  formats::CreateCaptureSession(session, planned);
  const formats::SessionManifest read = formats::ReadSessionManifest(session);
  const formats::RigDescription read_rig = formats::ParseRigDescription(read.rig, session / "manifest.json");
  for (std::size_t s = 0; s < read.plan.size(); ++s) {
    formats::ReadCaptureStep(read.plan[s], s, read_rig, session / "manifest.json");
  }
  corpus.AddFile("session_manifest", "tiny_rig_plan.json", session / formats::kSessionManifestName);

  const formats::SessionManifest manifest = TinySessionManifest();
  const fs::path journaled = corpus.Scratch("session") / "journaled";
  formats::CreateCaptureSession(journaled, manifest);
  const fs::path journal_file = journaled / formats::kSessionJournalName;
  {
    formats::CaptureJournal journal(journal_file, &manifest);
    for (const formats::PlannedStep& step : manifest.plan) {
      const std::string data = "data/" + step.id + ".bin";
      fs::create_directories(journaled / "data");
      WriteFileBytes(journaled / data, step.id);
      journal.Append({journal.next_seq(),
                      step.id,
                      formats::UtcTimestamp(std::chrono::system_clock::now()),
                      {{data, step.id.size()}}});
      formats::ReadCaptureJournal(journal_file, &manifest);
      corpus.AddFile("capture_journal", std::to_string(journal.next_seq()) + "_records.jsonl", journal_file);
    }
  }
  // A torn last line, which readers drop.
  const std::string whole = ReadFileBytes(journal_file);
  WriteFileBytes(journal_file, whole + whole.substr(0, whole.find('\n') / 2));
  if (formats::ReadCaptureJournal(journal_file, &manifest).dropped_bytes == 0) {
    throw core::Error("make_seed_corpus: the torn journal line was not dropped");
  }
  corpus.AddFile("capture_journal", "torn_tail.jsonl", journal_file);
}

void AddMaterialPackage(Corpus& corpus) {
  const fs::path package = corpus.Scratch("material") / "tiny";
  formats::WriteMaterialPackage(package, TinyMaterialPackage(), false);
  formats::ReadMaterialPackage(package);
  corpus.AddFile("material_manifest", "tiny.json", package / "manifest.json");
  // Numbered as material_package_part_fuzzer numbers them: the manifest left out.
  int part = 0;
  for (const fs::path& file : FilesOf(package)) {
    if (file == "manifest.json") continue;
    std::string name = file.string();
    std::replace(name.begin(), name.end(), '/', '_');
    corpus.AddFile("material_package_part", name, package / file, part++);
  }
}

void AddSweepAnalysis(Corpus& corpus) {
  const fs::path file = corpus.Scratch("sweep") / "sweep.json";
  formats::WriteSweepAnalysis(file, TinySweepAnalysis());
  formats::ReadSweepAnalysis(file);
  corpus.AddFile("sweep_analysis", "json", file, 0);
  corpus.AddFile("sweep_analysis", "exr", file.string() + ".exr", 1);
}

void AddFrameSequences(Corpus& corpus) {
  const fs::path dir = corpus.Scratch("frames");
  const struct {
    const char* name;
    int channels;
    core::PixelEncoding encoding;
    int frames;
  } sequences[] = {{"grey16.tif", 1, core::PixelEncoding::kUInt16, 3},
                   {"rgb8.tif", 3, core::PixelEncoding::kUInt8, 2},
                   {"float.tif", 1, core::PixelEncoding::kFloat32, 1}};
  for (const auto& s : sequences) {
    formats::FrameSequenceWriter writer(dir / s.name, 6, 4, s.channels, s.encoding);
    for (int f = 0; f < s.frames; ++f) writer.Append(TinyImage(6, 4, s.channels));
    writer.Commit();
    formats::FrameSequenceReader reader(dir / s.name);
    core::Image frame;
    while (reader.Next(&frame)) {
    }
    corpus.AddFile("frame_sequence", s.name, dir / s.name);
  }
}

void AddImages(Corpus& corpus) {
  const fs::path dir = corpus.Scratch("images");
  // Variants as image_fuzzer numbers them: .exr, .png, .tif.
  const struct {
    int variant;
    const char* extension;
    core::PixelEncoding encoding;
    int channels;
  } images[] = {{0, ".exr", core::PixelEncoding::kFloat32, 3}, {0, ".exr", core::PixelEncoding::kHalf, 1},
                {1, ".png", core::PixelEncoding::kUInt8, 3},   {1, ".png", core::PixelEncoding::kUInt16, 4},
                {2, ".tif", core::PixelEncoding::kUInt16, 1},  {2, ".tif", core::PixelEncoding::kFloat32, 3}};
  for (const auto& image : images) {
    const std::string name =
        std::string(core::ToString(image.encoding)) + "_" + std::to_string(image.channels) + image.extension;
    core::WriteImage(dir / name, TinyImage(5, 3, image.channels), image.encoding);
    core::ReadImage(dir / name);
    corpus.AddFile("image", name, dir / name, image.variant);
  }
}

void AddObjMeshAndSamplingSets(Corpus& corpus) {
  const fs::path dir = corpus.Scratch("json");
  WriteFileBytes(dir / "cube.obj", TinyObjText());
  formats::ReadObjMesh(dir / "cube.obj");
  corpus.AddFile("obj_mesh", "cube.obj", dir / "cube.obj");

  const core::SamplingSet sets[] = {core::SamplingSet::Named("paper12x5"), bonn::NamedSamplingSet("ubo2003"),
                                    core::SamplingSet::FromAngles("three", {{0.0, 0.0}, {0.5, 1.0}, {1.2, 5.0}})};
  for (const core::SamplingSet& set : sets) {
    const fs::path file = dir / (set.name() + ".json");
    WriteFileBytes(file, ToJson(set).dump());
    core::ReadSamplingSet(core::JsonFieldReader(core::ReadJsonFile(file), file));
    corpus.AddFile("sampling_set", set.name() + ".json", file);
  }
}

void AddFaultPlans(Corpus& corpus) {
  // The fault plan has no writer: these are docs/FORMATS.md's example rules.
  const std::string plans[] = {
      R"({"format": "mesocap.faults", "version": 1, "camera_drop_frame": {"rate": 0.01},
          "stage_stall": {"device": "turntable", "at": [3]},
          "lamp_failure": [{"device": 2, "at": [1]}, {"rate": 0.001}]})",
      R"({"format": "mesocap.faults", "version": 1, "camera_timeout": {"device": "cam0", "at": [1, 4, 9]},
          "camera_disconnect": {"rate": 0}, "stage_timeout": [{"device": "light_arc", "rate": 0.5}]})"};
  const fs::path dir = corpus.Scratch("faults");
  int i = 0;
  for (const std::string& plan : plans) {
    const fs::path file = dir / ("faults" + std::to_string(i++) + ".json");
    WriteFileBytes(file, plan);
    sim::ReadFaultPlan(file);
    corpus.AddFile("fault_plan", file.filename(), file);
  }
}

void AddRenderScenes(Corpus& corpus, const fs::path& source_dir) {
  const render::MaterialResolver resolver = [](const std::string& spec, const fs::path&) {
    render::RenderMaterial material;
    material.name = spec;
    material.sample_size_mm = 10.0;
    return material;
  };
  for (const fs::path& file : FilesOf(source_dir / "render" / "scenes")) {
    render::ReadRenderScene(source_dir / "render" / "scenes" / file, resolver);
    corpus.AddFile("render_scene", file.filename(), source_dir / "render" / "scenes" / file);
  }
}

void AddBonnForms(Corpus& corpus) {
  const core::FullBtf btf = *TinyMaterialPackage().full_btf;
  const fs::path dir = corpus.Scratch("bonn");
  btf::BtfCompressionOptions options;
  options.rank = 2;
  const bonn::BonnBtfFile fmf = bonn::BonnFmfFromFullBtf(btf, options);
  bonn::WriteBonnBtfFile(dir / "tiny.fmf", fmf, bonn::BonnScalar::kHalf);
  const core::FactoredBtf factored = bonn::FactoredFromBonn(bonn::ReadBonnBtfFile(dir / "tiny.fmf"), dir / "tiny.fmf");
  bonn::WriteBonnBtfFile(dir / "tiny.dfmf", bonn::BonnDfmfFromFactored(factored), bonn::BonnScalar::kFloat);
  // The other orientation (U rows = texels), which the reader also takes.
  bonn::BonnBtfFile texel_rows = bonn::BonnDfmfFromFactored(factored);
  texel_rows.row_space = bonn::BonnRowSpace::kTexels;
  for (auto& f : texel_rows.factors) std::swap(f.u, f.sxv);
  bonn::WriteBonnBtfFile(dir / "tiny_texel_rows.dfmf", texel_rows, bonn::BonnScalar::kHalf);
  for (const char* name : {"tiny.fmf", "tiny.dfmf", "tiny_texel_rows.dfmf"}) {
    bonn::FactoredFromBonn(bonn::ReadBonnBtfFile(dir / name), dir / name);
    corpus.AddFile("bonn_btf_file", name, dir / name);
  }

  // The UBO2003 fuzzer takes a folder's file names, one a line.
  const fs::path folder = corpus.Scratch("ubo2003");
  for (int v = 0; v < btf.view_count(); ++v) {
    bonn::WriteUbo2003View(folder, btf.views, btf.lights, v, btf.view_images[v], bonn::Ubo2003Encoding::kSrgb8Png, 1.0);
  }
  bonn::ReadUbo2003View(bonn::ScanUbo2003Folder(folder), 0, 1.0);
  std::string names;
  for (const fs::path& file : FilesOf(folder)) names += file.string() + "\n";
  corpus.Add("ubo2003_folder", "tiny.txt", names);
}

}  // namespace
}  // namespace mesocap::fuzz

int main(int argc, char** argv) {
  using namespace mesocap::fuzz;
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_seed_corpus OUT\n");
    return 2;
  }
  try {
    Corpus corpus(argv[1]);
    AddRigsAndCalibrations(corpus);
    AddSessions(corpus);
    AddMaterialPackage(corpus);
    AddSweepAnalysis(corpus);
    AddFrameSequences(corpus);
    AddImages(corpus);
    AddObjMeshAndSamplingSets(corpus);
    AddFaultPlans(corpus);
    AddRenderScenes(corpus, MESOCAP_SOURCE_DIR);
    AddBonnForms(corpus);
    std::printf("make_seed_corpus: %d seeds in %s\n", corpus.count(), argv[1]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "make_seed_corpus: %s\n", e.what());
    return 1;
  }
  return 0;
}
