#include "interop/bonn/bonn_ubo2003.h"

#include <OpenImageIO/color.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>
#include <optional>
#include <set>

#include "core/angles.h"
#include "core/error.h"
#include "interop/bonn/ubo_sampling_sets.h"

namespace mesocap::bonn {
namespace fs = std::filesystem;
namespace {

constexpr float kUbo2003HalfMax = 65504.0f;

// Degrees as a name writes them: three integer digits, and up to six
// decimals only when the angle is not whole.
std::string AngleText(double radians) {
  double deg = std::round(core::DegreesFromRadians(radians) * 1e6) / 1e6;
  if (deg >= 360.0) deg -= 360.0;
  char text[32];
  if (deg == std::round(deg)) {
    std::snprintf(text, sizeof text, "%03d", static_cast<int>(std::lround(deg)));
    return text;
  }
  std::snprintf(text, sizeof text, "%010.6f", deg);  // "005.625000"
  std::string s = text;
  while (s.back() == '0') s.pop_back();
  return s;
}

const char* Extension(Ubo2003Encoding encoding) { return encoding == Ubo2003Encoding::kSrgb8Png ? ".png" : ".exr"; }

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool IsImageExtension(const std::string& ext) {
  return ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".exr";
}

// The four angles (degrees) of a name: tl, pl, tv, pv.
struct NameAngles {
  std::array<double, 4> deg{};  // theta_l, phi_l, theta_v, phi_v
};

// Whether the stem looks like a Bonn image name at all (a token prefix and a
// digit): other files in the folder are ignored, these must parse.
bool LooksLikeBonnName(const std::string& stem) {
  if (stem.size() < 3) return false;
  const std::string p = Lower(stem.substr(0, 2));
  return (p == "tl" || p == "pl" || p == "tv" || p == "pv") && std::isdigit(static_cast<unsigned char>(stem[2]));
}

NameAngles ParseName(const fs::path& file);

}  // namespace

bool IsUbo2003ExportFolder(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(fs::symlink_status(dir, ec))) return false;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string extension = Lower(it->path().extension().string());
    if (!it->is_regular_file() || (extension != ".png" && extension != ".exr")) return false;
    try {
      ParseName(it->path());
    } catch (const core::Error&) {
      return false;
    }
  }
  return !ec;
}

namespace {

NameAngles ParseName(const fs::path& file) {
  static const std::array<const char*, 4> kTokens{"tl", "pl", "tv", "pv"};
  const std::string stem = file.stem().string();
  NameAngles out;
  std::array<bool, 4> seen{};
  std::size_t start = 0;
  int parts = 0;
  while (start <= stem.size()) {
    const std::size_t end = std::min(stem.find('_', start), stem.size());
    const std::string part = stem.substr(start, end - start);
    ++parts;
    const std::string prefix = Lower(part.substr(0, 2));
    const auto it = std::find_if(kTokens.begin(), kTokens.end(), [&](const char* t) { return prefix == t; });
    double value = 0.0;
    const char* first = part.data() + std::min<std::size_t>(2, part.size());
    const char* last = part.data() + part.size();
    const auto parsed = std::from_chars(first, last, value, std::chars_format::fixed);
    const bool digits_only =
        std::all_of(first, last, [](char c) { return std::isdigit(static_cast<unsigned char>(c)) || c == '.'; });
    if (it == kTokens.end() || first == last || parsed.ec != std::errc() || parsed.ptr != last || !digits_only) {
      throw core::FormatError(
          file, "name",
          "expected tl<deg>_pl<deg>_tv<deg>_pv<deg> (e.g. tl015_pl060_tv030_pv090), got part " + core::Quoted(part));
    }
    const int index = static_cast<int>(it - kTokens.begin());
    if (seen[index]) throw core::FormatError(file, "name", std::string("angle ") + kTokens[index] + " given twice");
    seen[index] = true;
    out.deg[index] = value;
    start = end + 1;
  }
  for (int i = 0; i < 4; ++i) {
    if (!seen[i])
      throw core::FormatError(file, "name", std::string("no ") + kTokens[i] + " angle (expected tl, pl, tv, pv)");
  }
  if (parts != 4) throw core::FormatError(file, "name", "expected exactly the four parts tl, pl, tv, pv");
  for (int i : {0, 2}) {
    if (out.deg[i] >= 90.0) {
      throw core::FormatError(file, "name",
                              std::string(kTokens[i]) + " " + std::to_string(out.deg[i]) +
                                  " degrees is not a polar angle of the upper hemisphere [0, 90)");
    }
  }
  for (int i : {1, 3}) {
    if (out.deg[i] >= 360.0) {
      throw core::FormatError(
          file, "name", std::string(kTokens[i]) + " " + std::to_string(out.deg[i]) + " degrees is outside [0, 360)");
    }
  }
  return out;
}

// Directions by (theta, phi) in degrees, at the pole phi 0 (mesocap's
// convention), ring by ring and by increasing phi.
using DegreePair = std::pair<double, double>;
DegreePair Key(double theta_deg, double phi_deg) { return {theta_deg, theta_deg == 0.0 ? 0.0 : phi_deg}; }

core::SamplingSet SetOf(const fs::path& dir, const std::set<DegreePair>& keys, const char* what) {
  std::vector<core::SphericalAngles> angles;
  for (const auto& [t, p] : keys) angles.push_back({core::RadiansFromDegrees(t), core::RadiansFromDegrees(p)});
  const core::SamplingSet named = NamedSamplingSet("ubo2003");
  if (named.size() == static_cast<int>(angles.size())) {
    bool same = true;
    for (int i = 0; i < named.size() && same; ++i) {
      same = std::abs(named.angles(i).theta - angles[i].theta) < 1e-9 &&
             std::abs(named.angles(i).phi - angles[i].phi) < 1e-9;
    }
    if (same) return named;
  }
  try {
    return core::SamplingSet::FromAngles("bonn_images", angles);
  } catch (const core::Error& e) {
    throw core::FormatError(dir, what, e.what());
  }
}

}  // namespace

std::string Ubo2003ImageName(const core::SphericalAngles& light, const core::SphericalAngles& view,
                             Ubo2003Encoding encoding) {
  return "tl" + AngleText(light.theta) + "_pl" + AngleText(light.phi) + "_tv" + AngleText(view.theta) + "_pv" +
         AngleText(view.phi) + Extension(encoding);
}

Ubo2003ImageSet ScanUbo2003Folder(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw core::Error(dir.string() + ": not a folder of Bonn BTF images");
  std::vector<fs::path> candidates;
  for (auto it = fs::recursive_directory_iterator(dir, ec); it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    if (ec) throw core::Error(dir.string() + ": cannot list: " + ec.message());
    if (it.depth() >= 1) it.disable_recursion_pending();  // the folder and its direct subfolders
    if (!it->is_regular_file()) continue;
    const fs::path& p = it->path();
    if (p.filename().string().starts_with(".")) continue;  // atomic-write temporaries, hidden files
    if (!IsImageExtension(Lower(p.extension().string())) || !LooksLikeBonnName(p.stem().string())) continue;
    candidates.push_back(p);
  }
  if (candidates.empty()) {
    throw core::Error(dir.string() + ": no Bonn BTF images (tl<deg>_pl<deg>_tv<deg>_pv<deg>.png/.tif/.exr) found");
  }
  std::sort(candidates.begin(), candidates.end());

  const std::string extension = Lower(candidates.front().extension().string());
  std::map<std::pair<DegreePair, DegreePair>, fs::path> by_pair;  // (view, light) -> file
  std::set<DegreePair> view_keys, light_keys;
  for (const auto& file : candidates) {
    if (Lower(file.extension().string()) != extension) {
      throw core::FormatError(file, "extension",
                              "expected every image in the same format as " + candidates.front().filename().string());
    }
    const NameAngles a = ParseName(file);
    const DegreePair light = Key(a.deg[0], a.deg[1]);
    const DegreePair view = Key(a.deg[2], a.deg[3]);
    const auto [it, inserted] = by_pair.emplace(std::make_pair(view, light), file);
    if (!inserted) {
      throw core::FormatError(file, "name", "the same light and view directions as " + it->second.string());
    }
    view_keys.insert(view);
    light_keys.insert(light);
  }

  Ubo2003ImageSet set;
  set.views = SetOf(dir, view_keys, "view directions");
  set.lights = SetOf(dir, light_keys, "light directions");
  const core::ImageHeader first = core::ReadImageHeader(candidates.front());
  if (first.channels != 3) {
    throw core::FormatError(candidates.front(), "channels", "expected 3 (RGB), got " + std::to_string(first.channels));
  }
  set.width = first.width;
  set.height = first.height;
  set.files.assign(set.views.size(), std::vector<fs::path>(set.lights.size()));
  int v = 0;
  for (const auto& view : view_keys) {
    int l = 0;
    for (const auto& light : light_keys) {
      const auto it = by_pair.find({view, light});
      if (it == by_pair.end()) {
        const Ubo2003Encoding enc = extension == ".exr" ? Ubo2003Encoding::kHalfExr : Ubo2003Encoding::kSrgb8Png;
        fs::path expected = dir / Ubo2003ImageName(set.lights.angles(l), set.views.angles(v), enc);
        expected.replace_extension(extension);
        throw core::FormatError(expected, "",
                                "missing: every light must be imaged from every view (" +
                                    std::to_string(light_keys.size()) + " lights x " +
                                    std::to_string(view_keys.size()) + " views seen); no image for light " +
                                    std::to_string(l) + ", view " + std::to_string(v));
      }
      const core::ImageHeader h = core::ReadImageHeader(it->second);
      if (h.width != first.width || h.height != first.height) {
        throw core::FormatError(it->second, h.width != first.width ? "width" : "height",
                                "expected " + std::to_string(first.width) + "x" + std::to_string(first.height) +
                                    " like " + candidates.front().filename().string() + ", got " +
                                    std::to_string(h.width) + "x" + std::to_string(h.height));
      }
      if (h.channels != 3) {
        throw core::FormatError(it->second, "channels", "expected 3 (RGB), got " + std::to_string(h.channels));
      }
      if ((h.encoding == core::PixelEncoding::kFloat32 || h.encoding == core::PixelEncoding::kHalf) !=
          (first.encoding == core::PixelEncoding::kFloat32 || first.encoding == core::PixelEncoding::kHalf)) {
        throw core::FormatError(it->second, "pixel type",
                                std::string("expected ") + ToString(first.encoding) + " like " +
                                    candidates.front().filename().string() + ", got " + ToString(h.encoding));
      }
      set.files[v][l] = it->second;
      ++l;
    }
    ++v;
  }
  return set;
}

core::Image ReadUbo2003View(const Ubo2003ImageSet& set, int view, double scale) {
  if (view < 0 || view >= set.views.size())
    throw core::Error("Bonn image view " + std::to_string(view) + " out of range");
  if (!(scale > 0.0) || !std::isfinite(scale)) throw core::Error("Bonn image scale must be a positive number");
  const int w = set.width, h = set.height;
  core::Image out(w, h * set.lights.size(), 3);
  core::ImageReadOptions options;
  options.expected_width = w;
  options.expected_height = h;
  options.expected_channels = 3;
  for (int l = 0; l < set.lights.size(); ++l) {
    const fs::path& file = set.files[view][l];
    const core::ImageHeader header = core::ReadImageHeader(file);
    const bool srgb = header.encoding == core::PixelEncoding::kUInt8 || header.encoding == core::PixelEncoding::kUInt16;
    const core::Image image = core::ReadImage(file, options);
    for (int y = 0; y < h; ++y) {
      const float* src = image.pixel(0, y);
      float* dst = out.pixel(0, l * h + y);
      for (int i = 0; i < w * 3; ++i) {
        const float v = srgb ? OIIO::sRGB_to_linear(src[i]) : src[i];
        if (!std::isfinite(v)) {
          throw core::FormatError(
              file, "pixels", "value at x=" + std::to_string(i / 3) + ", y=" + std::to_string(y) + " is not finite");
        }
        dst[i] = static_cast<float>(v / scale);
      }
    }
  }
  return out;
}

long long WriteUbo2003View(const fs::path& dir, const core::SamplingSet& views, const core::SamplingSet& lights,
                           int view, const core::Image& values, Ubo2003Encoding encoding, double scale) {
  if (!(scale > 0.0) || !std::isfinite(scale)) throw core::Error("Bonn image scale must be a positive number");
  const int h = lights.size() > 0 ? values.height() / lights.size() : 0;
  if (values.channels() != 3 || h <= 0 || h * lights.size() != values.height()) {
    throw core::Error("Bonn image export: view image " + std::to_string(values.width()) + "x" +
                      std::to_string(values.height()) + " does not hold " + std::to_string(lights.size()) + " lights");
  }
  const int w = values.width();
  long long clipped = 0;
  for (int l = 0; l < lights.size(); ++l) {
    core::Image image(w, h, 3);
    for (int y = 0; y < h; ++y) {
      const float* src = values.pixel(0, l * h + y);
      float* dst = image.pixel(0, y);
      for (int i = 0; i < w * 3; ++i) {
        const float v = static_cast<float>(src[i] * scale);
        if (encoding == Ubo2003Encoding::kSrgb8Png) {
          if (!(v >= 0.0f && v <= 1.0f)) ++clipped;
          // WriteImage maps [0, 1] to codes 0..255 (rounded, clamped).
          dst[i] = OIIO::linear_to_sRGB(std::clamp(v, 0.0f, 1.0f));
        } else {
          if (!(std::abs(v) <= kUbo2003HalfMax)) {
            throw core::Error("Bonn image export: value " + std::to_string(v) + " (view " + std::to_string(view) +
                              ", light " + std::to_string(l) + ") does not fit a half float (|v| <= 65504)");
          }
          dst[i] = v;
        }
      }
    }
    const fs::path file = dir / Ubo2003ImageName(lights.angles(l), views.angles(view), encoding);
    core::WriteImage(file, image,
                     encoding == Ubo2003Encoding::kSrgb8Png ? core::PixelEncoding::kUInt8 : core::PixelEncoding::kHalf);
  }
  return clipped;
}

}  // namespace mesocap::bonn
