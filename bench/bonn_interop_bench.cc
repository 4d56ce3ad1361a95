// Export and import through the Bonn BTF database forms, time beside the
// round-trip error (pipelines/export_bonn.h, pipelines/import_bonn.h):
//  - Export/<form>, Import/<form> for ubo2003 (8-bit sRGB PNG), ubo2003_exr
//    (half), dfmf and fmf (half factors, rank chosen by the default 1%
//    budget), on the exact BTF of `weave` (sim ground truth, 32 x 32 texels,
//    grid12x4 views and lights: 48 x 48 directions, 28 MB of floats).
//  - Import counters: relative RMS and largest absolute error of the
//    imported BTF against the truth; for fmf/dfmf also the truncation error
//    of the factors before quantization (the export's compression report),
//    so the quantization's share shows.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>

#include "formats/material_manifest.h"
#include "formats/material_package_reader.h"
#include "pipelines/export_bonn.h"
#include "pipelines/import_bonn.h"
#include "sim/ground_truth.h"
#include "sim/mesostructure_scene.h"

namespace mesocap {
namespace {
namespace fs = std::filesystem;

fs::path WorkDir() {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("mesocap-bonn-bench-" + std::to_string(::getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

const core::FullBtf& Truth() {
  static const core::FullBtf btf = [] {
    sim::GroundTruthOptions gt;
    gt.texels.width = gt.texels.height = 32;
    gt.texels.sample_size_mm = 12.0;
    gt.views = core::SamplingSet::Named("grid12x4");
    gt.lights = core::SamplingSet::Named("grid12x4");
    const auto scene = sim::MakeBuiltinScene("weave");
    sim::WriteGroundTruthPackage(*scene, gt, nullptr, "bench", WorkDir() / "weave", true,
                                 core::Progress::Style::kSilent);
    return sim::RenderTrueBtf(*scene, gt);
  }();
  return btf;
}

struct Form {
  pipelines::ExportBonnOptions options;  // in and out are set where it is run
  std::string out;
};

pipelines::ExportBonnReport ExportBonn(const fs::path& in, const fs::path& out, pipelines::ExportBonnOptions options) {
  options.in = in;
  options.out = out;
  return pipelines::RunExportBonn(options);
}

void ImportBonn(const fs::path& in, const fs::path& out, pipelines::ImportBonnOptions options) {
  options.in = in;
  options.out = out;
  pipelines::RunImportBonn(options);
}

// The 8-bit images hold [0, 1]: scale the brightest value (weave has
// highlights above 1) to 1 so that the error is quantization, not clipping.
double ImageScale() {
  float brightest = 0.0f;
  for (const core::Image& view : Truth().view_images)
    for (std::size_t i = 0; i < view.size(); ++i) brightest = std::max(brightest, view.data()[i]);
  return 1.0 / brightest;
}

std::map<std::string, Form> Forms() {
  std::map<std::string, Form> forms;
  Form f;
  f.options.replace = true;
  f.options.form = bonn::BonnForm::kUbo2003;
  f.options.scale = ImageScale();
  forms["ubo2003"] = f;
  f.options.encoding = bonn::Ubo2003Encoding::kHalfExr;
  forms["ubo2003_exr"] = f;
  f.options.form = bonn::BonnForm::kDfmf;
  forms["dfmf"] = f;
  f.options.form = bonn::BonnForm::kFmf;
  forms["fmf"] = f;
  for (auto& [name, form] : forms) form.out = (WorkDir() / (name + ".out")).string();
  return forms;
}

std::map<std::string, double> truncation;  // relative RMS of the factors before quantization

void Export(benchmark::State& state, const std::string& name) {
  Truth();
  const Form form = Forms().at(name);
  for (auto _ : state) {
    const pipelines::ExportBonnReport r = ExportBonn(WorkDir() / "weave", form.out, form.options);
    if (r.compression) {
      truncation[name] = r.compression->measured_relative_rms_error;
      state.counters["rank"] = r.rank;
    }
  }
}

void Import(benchmark::State& state, const std::string& name) {
  const core::FullBtf& truth = Truth();
  const Form form = Forms().at(name);
  if (!fs::exists(form.out)) ExportBonn(WorkDir() / "weave", form.out, form.options);
  pipelines::ImportBonnOptions o;
  o.d_max_mm = 3.0;
  o.width_mm = 12.0;
  o.replace = true;
  o.parts = pipelines::BonnImportParts::kFull;
  o.scale = form.options.scale;
  const fs::path out = WorkDir() / (name + ".imported");
  for (auto _ : state) ImportBonn(form.out, out, o);
  const core::FullBtf got = formats::ReadFullBtf(out, formats::ReadMaterialManifest(out));
  // ||a - b|| / ||truth||, and the largest |a - b|.
  auto compare = [&](const core::FullBtf& a, const core::FullBtf& b, double* worst) {
    double err = 0, norm = 0;
    for (int v = 0; v < truth.view_count(); ++v)
      for (std::size_t i = 0; i < truth.view_images[v].size(); ++i) {
        const double d = a.view_images[v].data()[i] - b.view_images[v].data()[i];
        const double t = truth.view_images[v].data()[i];
        err += d * d;
        norm += t * t;
        *worst = std::max(*worst, std::abs(d));
      }
    return std::sqrt(err / norm);
  };
  double worst = 0.0;
  state.counters["rel_rms"] = compare(got, truth, &worst);
  state.counters["max_abs"] = worst;
  if (truncation.count(name)) state.counters["truncation_rel_rms"] = truncation[name];
  if (form.options.form != bonn::BonnForm::kUbo2003) {
    // The same factors written as float: the difference is the half quantization.
    pipelines::ExportBonnOptions f = form.options;
    f.scalar = bonn::BonnScalar::kFloat;
    const fs::path float_file = WorkDir() / (name + ".float");
    ExportBonn(WorkDir() / "weave", float_file, f);
    ImportBonn(float_file, WorkDir() / (name + ".float.imported"), o);
    const fs::path float_out = WorkDir() / (name + ".float.imported");
    double q_worst = 0.0;
    state.counters["half_vs_float_rel_rms"] =
        compare(got, formats::ReadFullBtf(float_out, formats::ReadMaterialManifest(float_out)), &q_worst);
    state.counters["half_vs_float_max_abs"] = q_worst;
  }
}

void Register() {
  for (const char* name : {"ubo2003", "ubo2003_exr", "dfmf", "fmf"}) {
    benchmark::RegisterBenchmark((std::string("Export/") + name).c_str(), Export, std::string(name))
        ->Unit(benchmark::kMillisecond)
        ->Iterations(1)
        ->Repetitions(3)
        ->ReportAggregatesOnly(true);
    benchmark::RegisterBenchmark((std::string("Import/") + name).c_str(), Import, std::string(name))
        ->Unit(benchmark::kMillisecond)
        ->Iterations(1)
        ->Repetitions(1);
  }
}

}  // namespace
}  // namespace mesocap

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  mesocap::Register();
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  std::filesystem::remove_all(mesocap::WorkDir());
  return 0;
}
