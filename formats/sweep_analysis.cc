#include "formats/sweep_analysis.h"

#include <cmath>
#include <string>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/json_field_reader.h"

namespace mesocap::formats {

namespace {

std::filesystem::path ImageFile(const std::filesystem::path& file) {
  std::filesystem::path image = file;
  image += ".exr";
  return image;
}

}  // namespace

std::string SweepAnalysisImagePath(const std::string& path) { return ImageFile(path).string(); }

void WriteSweepAnalysis(const std::filesystem::path& file, const SweepAnalysis& analysis) {
  const std::size_t n = static_cast<std::size_t>(analysis.width) * analysis.height;
  if (analysis.peak_time.size() != n || analysis.peak_value.size() != n || analysis.second_time.size() != n ||
      analysis.second_value.size() != n || analysis.planes.size() != static_cast<std::size_t>(analysis.frame_count)) {
    throw core::Error("sweep analysis " + file.string() + ": sizes do not match width, height and frame_count");
  }
  core::Image image(analysis.width, analysis.height, 4);
  for (std::size_t p = 0; p < n; ++p) {
    image.data()[4 * p] = analysis.peak_time[p];
    image.data()[4 * p + 1] = analysis.peak_value[p];
    image.data()[4 * p + 2] = analysis.second_time[p];
    image.data()[4 * p + 3] = analysis.second_value[p];
  }
  core::WriteImage(ImageFile(file), image, core::PixelEncoding::kFloat32);
  nlohmann::json planes = nlohmann::json::array();
  for (const core::Plane& plane : analysis.planes) planes.push_back(ToJson(plane));
  core::WriteJsonFileAtomically(file, {{"format", "mesocap.sweep_analysis"},
                                       {"version", 2},
                                       {"width", analysis.width},
                                       {"height", analysis.height},
                                       {"frame_count", analysis.frame_count},
                                       {"image", ImageFile(file).filename().string()},
                                       {"planes", planes}});
}

SweepAnalysis ReadSweepAnalysis(const std::filesystem::path& file) {
  const nlohmann::json doc = core::ReadJsonFile(file, 64ull << 20);
  const core::JsonFieldReader root(doc, file);
  const int version = root.ExpectFormat("mesocap.sweep_analysis", 1, 2);
  root.RejectUnknownMembers({"format", "version", "width", "height", "frame_count", "image", "planes"});
  SweepAnalysis analysis;
  analysis.width = static_cast<int>(root.Integer("width", 1, 1 << 15));
  analysis.height = static_cast<int>(root.Integer("height", 1, 1 << 15));
  analysis.frame_count = static_cast<int>(root.Integer("frame_count", 1, 1 << 20));
  if (const std::string image = root.String("image"); image != ImageFile(file).filename().string()) {
    root.Fail("image", "expected " + core::Quoted(ImageFile(file).filename().string()) + " (the file beside it), got " +
                           core::Quoted(image));
  }
  const nlohmann::json& planes = root.Raw("planes");
  if (!planes.is_array() || planes.size() != static_cast<std::size_t>(analysis.frame_count)) {
    root.Fail("planes",
              "expected one plane or null per frame (frame_count = " + std::to_string(analysis.frame_count) +
                  "), got " +
                  (planes.is_array() ? std::to_string(planes.size()) + " entries" : core::JsonExcerpt(planes)));
  }
  for (std::size_t i = 0; i < doc["planes"].size(); ++i) {
    analysis.planes.push_back(core::PlaneFromJson(doc["planes"][i], file, "planes[" + std::to_string(i) + "]"));
  }
  core::ImageReadOptions options;
  options.expected_width = analysis.width;
  options.expected_height = analysis.height;
  const int channels = version == 1 ? 2 : 4;  // version 1: no second peaks
  options.expected_channels = channels;
  const core::Image image = core::ReadImage(ImageFile(file), options);
  const std::size_t n = static_cast<std::size_t>(analysis.width) * analysis.height;
  analysis.peak_time.resize(n);
  analysis.peak_value.resize(n);
  analysis.second_time.assign(n, std::numeric_limits<float>::quiet_NaN());
  analysis.second_value.assign(n, 0.0f);
  auto frame_time = [&](float t, const char* field) {
    if (!std::isnan(t) && !(t >= 0 && t <= analysis.frame_count - 1)) {
      throw core::FormatError(ImageFile(file), field, "NaN or a frame time in [0, frame_count - 1]");
    }
    return t;
  };
  auto fraction = [&](float v, const char* field) {
    if (!(v >= 0 && v <= 1)) {
      throw core::FormatError(ImageFile(file), field,
                              "expected a fraction of full scale in [0, 1], got " + std::to_string(v));
    }
    return v;
  };
  for (std::size_t p = 0; p < n; ++p) {
    const float* texel = image.data() + channels * p;
    analysis.peak_time[p] = frame_time(texel[0], "peak time");
    analysis.peak_value[p] = fraction(texel[1], "peak value");
    if (channels == 4) {
      analysis.second_time[p] = frame_time(texel[2], "second peak time");
      analysis.second_value[p] = fraction(texel[3], "second peak value");
    }
  }
  return analysis;
}

}  // namespace mesocap::formats
