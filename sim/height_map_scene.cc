// A height map image as a scene: one tile whose pixel (x, y) (Image::at
// order, x along +X, row y along +Y) is a grid vertex at the pixel centre.
#include <cmath>
#include <string>

#include "core/error.h"
#include "core/image_io.h"
#include "sim/tile_geometry.h"
#include "sim/tiled_scene.h"

namespace mesocap::sim {
namespace fs = std::filesystem;
namespace {

// 1024 x 1024 pixels is 2 M triangles: enough for a tile, and a bound on
// memory that a hostile header cannot push up.
constexpr long kMaxPixels = 1024L * 1024L;

// The height value of a pixel: its only channel, the grey of grey + alpha,
// or the luminance (Rec. 709, linear) of RGB(A).
float ValueAt(const core::Image& image, int x, int y) {
  if (image.channels() <= 2) return image.at(x, y, 0);
  return 0.2126f * image.at(x, y, 0) + 0.7152f * image.at(x, y, 1) + 0.0722f * image.at(x, y, 2);
}

}  // namespace

std::unique_ptr<MesostructureScene> LoadHeightMapScene(const fs::path& image_file, double tile_size_mm,
                                                       double depth_mm) {
  if (!(tile_size_mm > 0.0) || !std::isfinite(tile_size_mm) || !(depth_mm > 0.0) || !std::isfinite(depth_mm)) {
    throw core::Error(image_file.string() + ": height map tile size and depth must be positive and finite, got " +
                      std::to_string(tile_size_mm) + " and " + std::to_string(depth_mm) + " mm");
  }
  const core::ImageHeader header = core::ReadImageHeader(image_file);
  if (static_cast<long>(header.width) * header.height > kMaxPixels) {
    throw core::FormatError(image_file, "size",
                            "a height map may have at most " + std::to_string(kMaxPixels) + " pixels, got " +
                                std::to_string(header.width) + "x" + std::to_string(header.height));
  }
  const core::Image image = core::ReadImage(image_file);
  const int w = image.width();
  const int h = image.height();

  TileGeometry g{.name = image_file.filename().string(), .tile_size_mm = tile_size_mm, .d_max_mm = depth_mm};
  // Vertices (w + 1) x (h + 1): the last column and row repeat the first at
  // one period further, which closes the surface across the tile border.
  for (int y = 0; y <= h; ++y) {
    for (int x = 0; x <= w; ++x) {
      const float value = ValueAt(image, x % w, y % h);
      if (!(value >= 0.0f && value <= 1.0f)) {
        throw core::FormatError(image_file, "pixel (" + std::to_string(x % w) + ", " + std::to_string(y % h) + ")",
                                "height value " + std::to_string(value) + " is outside [0, 1]");
      }
      g.AddVertex({(x + 0.5) * tile_size_mm / w, (y + 0.5) * tile_size_mm / h, -depth_mm * (1.0 - value)});
    }
  }
  const int surface = g.AddPart(Reflectance{});  // no material in a height map: grey 0.5
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const int a = y * (w + 1) + x;
      g.AddQuad(a, a + 1, a + w + 2, a + w + 1, surface);
    }
  }
  g.AddBase(-depth_mm, surface);  // the solid's floor
  return MakeTiledScene(std::move(g));
}

}  // namespace mesocap::sim
