#include "formats/obj_mesh.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <string>
#include <string_view>

#include "core/error.h"

namespace mesocap::formats {
namespace fs = std::filesystem;
namespace {

// Every coordinate (vertex, texture coordinate, normal) in the file's units:
// far beyond any mesh mesocap draws or simulates, and small enough that the
// float vertices of the renderers keep their meaning (1e308 would not).
constexpr double kMaxObjCoordinate = 1e6;

std::vector<std::string_view> SplitWhitespace(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const std::size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

// Whole-token number parse: "1.5x" is an error, not 1.5.
template <class Number>
bool ParseNumber(std::string_view token, Number* value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto [end, error] = std::from_chars(token.data(), token.data() + token.size(), *value);
  return error == std::errc() && end == token.data() + token.size();
}

}  // namespace

ObjMesh ReadObjMesh(const fs::path& file) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw core::FormatError(file, "", "not found or not a regular file");
  std::ifstream in(file);
  if (!in) throw core::FormatError(file, "", "cannot open the file");
  ObjMesh mesh;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    const auto fail = [&](const std::string& problem) {
      throw core::FormatError(file, "line " + std::to_string(number), problem);
    };
    const std::vector<std::string_view> tokens = SplitWhitespace(line);
    if (tokens.empty() || tokens[0].front() == '#') continue;
    const auto read = [&](int count, const char* what) {
      // "v x y z [w]" or "v x y z r g b", "vt u v [w]": the first `count` are used.
      Eigen::Vector3d v = Eigen::Vector3d::Zero();
      if (static_cast<int>(tokens.size()) < count + 1) {
        fail(std::string("a ") + what + " needs " + std::to_string(count) + " coordinates");
      }
      for (int k = 0; k < count; ++k) {
        if (!ParseNumber(tokens[k + 1], &v[k]))
          fail(std::string(what) + " coordinate " + core::Quoted(tokens[k + 1]) + " is not a number");
        if (!(std::abs(v[k]) <= kMaxObjCoordinate)) {
          fail(std::string(what) + " coordinate " + core::Cut(tokens[k + 1]) + " is outside [-1e+06, 1e+06]");
        }
      }
      return v;
    };
    if (tokens[0] == "v") {
      mesh.positions.push_back(read(3, "vertex"));
    } else if (tokens[0] == "vt") {
      mesh.texcoords.push_back(read(2, "texture coordinate").head<2>());
    } else if (tokens[0] == "vn") {
      mesh.normals.push_back(read(3, "normal"));
    } else if (tokens[0] == "f") {
      if (tokens.size() < 4) fail("a face needs at least 3 vertices");
      const auto index = [&](std::string_view part, std::size_t count, const char* what, bool optional) {
        if (part.empty() && optional) return -1;
        long i = 0;
        if (!ParseNumber(part, &i)) fail("face index " + core::Quoted(part) + " is not an integer");
        const long n = static_cast<long>(count);
        if (i < 0) i += n + 1;  // -1 is the last element so far
        if (i < 1 || i > n) {
          fail("face index " + core::Cut(part) + " does not name one of the " + std::to_string(n) + " " + what +
               " so far");
        }
        return static_cast<int>(i - 1);
      };
      std::vector<ObjMesh::Corner> face;
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const std::string_view corner = tokens[k];
        const std::size_t s1 = corner.find('/');
        const std::size_t s2 = s1 == std::string_view::npos ? s1 : corner.find('/', s1 + 1);
        ObjMesh::Corner c;
        c.position = index(corner.substr(0, s1), mesh.positions.size(), "vertices", false);
        if (s1 != std::string_view::npos) {
          c.texcoord = index(corner.substr(s1 + 1, s2 == std::string_view::npos ? s2 : s2 - s1 - 1),
                             mesh.texcoords.size(), "texture coordinates", true);
        }
        if (s2 != std::string_view::npos) {
          c.normal = index(corner.substr(s2 + 1), mesh.normals.size(), "normals", true);
        }
        face.push_back(c);
      }
      // A fan: exact for the triangles and convex polygons OBJ exporters write.
      for (std::size_t k = 1; k + 1 < face.size(); ++k) mesh.triangles.push_back({face[0], face[k], face[k + 1]});
    }
  }
  if (in.bad()) throw core::FormatError(file, "", "read error");
  if (mesh.triangles.empty()) throw core::FormatError(file, "f", "the mesh has no faces");
  return mesh;
}

}  // namespace mesocap::formats
