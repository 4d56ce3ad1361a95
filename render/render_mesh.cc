#include "render/render_mesh.h"
#include "core/angles.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <tuple>

#include "core/error.h"
#include "formats/obj_mesh.h"

namespace mesocap::render {
namespace {

// A closed parametric surface P(u, v) on [0,1]^2, periodic in u (and in v
// when `periodic_v`), sampled on a (nu+1) x (nv+1) grid: the seam vertices are
// duplicated for their texture coordinates but copy the positions and normals
// of the first column/row bit for bit, so the mesh (and its displaced shell)
// has no cracks. Normals from central differences of P, outward when
// dP/du x dP/dv points outward.
void AppendParametric(const std::function<Eigen::Vector3d(double, double)>& surface, int nu, int nv, bool periodic_v,
                      const Eigen::Vector2d& tiles, RenderMesh* mesh) {
  const int base = mesh->vertex_count();
  constexpr double h = 1e-5;
  for (int j = 0; j <= nv; ++j) {
    for (int i = 0; i <= nu; ++i) {
      const int si = i == nu ? 0 : i;
      const int sj = (periodic_v && j == nv) ? 0 : j;
      const double u = static_cast<double>(si) / nu;
      const double v = static_cast<double>(sj) / nv;
      const Eigen::Vector3d p = surface(u, v);
      const Eigen::Vector3d du = surface(u + h, v) - surface(u - h, v);
      const Eigen::Vector3d dv = surface(u, v + h) - surface(u, v - h);
      mesh->positions.push_back(p.cast<float>());
      mesh->normals.push_back(du.cross(dv).normalized().cast<float>());
      mesh->texcoords.emplace_back(static_cast<float>(tiles.x() * i / nu), static_cast<float>(tiles.y() * j / nv));
    }
  }
  for (int j = 0; j < nv; ++j) {
    for (int i = 0; i < nu; ++i) {
      const int a = base + j * (nu + 1) + i;
      const int b = a + 1;
      const int c = a + (nu + 1) + 1;
      const int d = a + (nu + 1);
      mesh->triangles.emplace_back(a, b, c);
      mesh->triangles.emplace_back(a, c, d);
    }
  }
}

}  // namespace

void ComputeTangentFrames(RenderMesh* mesh, double sample_size_mm) {
  const std::size_t n = mesh->positions.size();
  if (mesh->normals.size() != n || mesh->texcoords.size() != n) {
    throw core::Error("mesh: positions, normals and texture coordinates differ in count");
  }
  std::vector<Eigen::Vector3d> sum_dx(n, Eigen::Vector3d::Zero()), sum_dy(n, Eigen::Vector3d::Zero());
  std::vector<double> sum_lx(n, 0.0), sum_ly(n, 0.0), sum_area(n, 0.0);
  for (const Eigen::Vector3i& t : mesh->triangles) {
    const Eigen::Vector3d p0 = mesh->positions[t[0]].cast<double>();
    const Eigen::Vector3d e1 = mesh->positions[t[1]].cast<double>() - p0;
    const Eigen::Vector3d e2 = mesh->positions[t[2]].cast<double>() - p0;
    const Eigen::Vector2d t1 = (mesh->texcoords[t[1]] - mesh->texcoords[t[0]]).cast<double>();
    const Eigen::Vector2d t2 = (mesh->texcoords[t[2]] - mesh->texcoords[t[0]]).cast<double>();
    const double det = t1.x() * t2.y() - t2.x() * t1.y();
    // Collinear texture coordinates (a degenerate mapping): no gradient.
    if (std::abs(det) <= 1e-12 * (t1.squaredNorm() + t2.squaredNorm())) continue;
    const Eigen::Vector3d dx = (e1 * t2.y() - e2 * t1.y()) / det;
    const Eigen::Vector3d dy = (e2 * t1.x() - e1 * t2.x()) / det;
    const double area = 0.5 * e1.cross(e2).norm();
    for (int k = 0; k < 3; ++k) {
      sum_dx[t[k]] += area * dx;
      sum_dy[t[k]] += area * dy;
      sum_lx[t[k]] += area * dx.norm();
      sum_ly[t[k]] += area * dy.norm();
      sum_area[t[k]] += area;
    }
  }
  mesh->tangents.assign(n, Eigen::Vector4f(1, 0, 0, 1));
  mesh->texture_scale.assign(n, 0.0f);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d normal = mesh->normals[i].cast<double>();
    Eigen::Vector3d tangent = sum_dx[i] - normal * normal.dot(sum_dx[i]);
    if (sum_area[i] <= 0.0 || tangent.norm() <= 1e-12 * sum_dx[i].norm() || tangent.norm() == 0.0) {
      // No usable face: any frame orthogonal to the normal.
      tangent = normal.unitOrthogonal();
      mesh->tangents[i] << tangent.cast<float>(), 1.0f;
      continue;
    }
    tangent.normalize();
    const float handedness = normal.cross(tangent).dot(sum_dy[i]) >= 0.0 ? 1.0f : -1.0f;
    mesh->tangents[i] << tangent.cast<float>(), handedness;
    mesh->texture_scale[i] =
        static_cast<float>(std::sqrt(sum_lx[i] / sum_area[i] * sum_ly[i] / sum_area[i]) / sample_size_mm);
  }
}

RenderMesh MakeCylinderSide(double radius, double height, int segments, int rings, Eigen::Vector2d tiles) {
  RenderMesh mesh;
  AppendParametric(
      [&](double u, double v) {
        return Eigen::Vector3d(radius * std::cos(core::kTwoPi * u), radius * std::sin(core::kTwoPi * u), height * v);
      },
      std::max(segments, 3), std::max(rings, 1), false, tiles, &mesh);
  return mesh;
}

RenderMesh MakeCylinderCaps(double radius, double height, int segments, Eigen::Vector2d tiles) {
  segments = std::max(segments, 3);
  // The rim copies the side's first row exactly (same formula), so the caps
  // meet the side without cracks.
  const RenderMesh side = MakeCylinderSide(radius, height, segments, 1, tiles);
  RenderMesh mesh;
  // Caps: a fan each, texture coordinates planar at the side's density.
  const double density = tiles.x() / (core::kTwoPi * radius);
  for (const bool top : {false, true}) {
    const float z = top ? static_cast<float>(height) : 0.0f;
    const Eigen::Vector3f normal(0, 0, top ? 1.0f : -1.0f);
    const int centre = mesh.vertex_count();
    mesh.positions.emplace_back(0.0f, 0.0f, z);
    mesh.normals.push_back(normal);
    mesh.texcoords.emplace_back(0.0f, 0.0f);
    const int rim_row = top ? segments + 1 : 0;
    for (int i = 0; i < segments; ++i) {
      const Eigen::Vector3f p = side.positions[rim_row + i];
      mesh.positions.push_back(p);
      mesh.normals.push_back(normal);
      mesh.texcoords.emplace_back(static_cast<float>(p.x() * density), static_cast<float>(p.y() * density));
    }
    for (int i = 0; i < segments; ++i) {
      const int a = centre + 1 + i;
      const int b = centre + 1 + (i + 1) % segments;
      mesh.triangles.emplace_back(top ? Eigen::Vector3i(centre, a, b) : Eigen::Vector3i(centre, b, a));
    }
  }
  return mesh;
}

RenderMesh MakeCylinder(double radius, double height, int segments, int rings, Eigen::Vector2d tiles) {
  RenderMesh mesh = MakeCylinderSide(radius, height, segments, rings, tiles);
  const RenderMesh caps = MakeCylinderCaps(radius, height, segments, tiles);
  const int base = mesh.vertex_count();
  mesh.positions.insert(mesh.positions.end(), caps.positions.begin(), caps.positions.end());
  mesh.normals.insert(mesh.normals.end(), caps.normals.begin(), caps.normals.end());
  mesh.texcoords.insert(mesh.texcoords.end(), caps.texcoords.begin(), caps.texcoords.end());
  for (const Eigen::Vector3i& t : caps.triangles) mesh.triangles.push_back(t + Eigen::Vector3i::Constant(base));
  return mesh;
}

RenderMesh MakeTorus(double major_radius, double minor_radius, int major_segments, int minor_segments,
                     Eigen::Vector2d tiles) {
  RenderMesh mesh;
  AppendParametric(
      [&](double u, double v) {
        const double ring = major_radius + minor_radius * std::cos(core::kTwoPi * v);
        return Eigen::Vector3d(ring * std::cos(core::kTwoPi * u), ring * std::sin(core::kTwoPi * u),
                               minor_radius * std::sin(core::kTwoPi * v));
      },
      std::max(major_segments, 3), std::max(minor_segments, 3), true, tiles, &mesh);
  return mesh;
}

RenderMesh MakeTorusKnot(double radius, double tube_radius, int p, int q, int segments, int tube_segments,
                         Eigen::Vector2d tiles) {
  // The centre curve ((2 + cos q a) cos p a, (2 + cos q a) sin p a, -sin q a) R/3
  // has no point of zero curvature, so its Frenet frame is smooth and periodic.
  const auto curve = [=](double u) -> Eigen::Vector3d {
    const double a = core::kTwoPi * u;
    const double ring = 2.0 + std::cos(q * a);
    return Eigen::Vector3d(ring * std::cos(p * a), ring * std::sin(p * a), -std::sin(q * a)) * (radius / 3.0);
  };
  RenderMesh mesh;
  AppendParametric(
      [&](double u, double v) {
        constexpr double h = 1e-4;
        const Eigen::Vector3d c = curve(u);
        const Eigen::Vector3d tangent = (curve(u + h) - curve(u - h)).normalized();
        const Eigen::Vector3d bend = curve(u + h) + curve(u - h) - 2.0 * c;
        const Eigen::Vector3d normal = (bend - tangent * tangent.dot(bend)).normalized();
        const Eigen::Vector3d binormal = tangent.cross(normal);
        // Angle -2 pi v so that dP/du x dP/dv points out of the tube.
        const double angle = -core::kTwoPi * v;
        return Eigen::Vector3d(c + tube_radius * (std::cos(angle) * normal + std::sin(angle) * binormal));
      },
      std::max(segments, 3), std::max(tube_segments, 3), true, tiles, &mesh);
  return mesh;
}

RenderMesh MakeBox(const Eigen::Vector3d& min, const Eigen::Vector3d& max, double tiles_per_100mm) {
  RenderMesh mesh;
  const double density = tiles_per_100mm / 100.0;
  for (int axis = 0; axis < 3; ++axis) {
    for (const int side : {-1, 1}) {
      const int a = (axis + 1) % 3;
      const int b = (axis + 2) % 3;
      const int base = mesh.vertex_count();
      Eigen::Vector3f normal = Eigen::Vector3f::Zero();
      normal[axis] = static_cast<float>(side);
      for (int k = 0; k < 4; ++k) {
        Eigen::Vector3d p;
        p[axis] = side > 0 ? max[axis] : min[axis];
        p[a] = (k == 1 || k == 2) ? max[a] : min[a];
        p[b] = (k >= 2) ? max[b] : min[b];
        mesh.positions.push_back(p.cast<float>());
        mesh.normals.push_back(normal);
        mesh.texcoords.emplace_back(static_cast<float>(p[a] * density), static_cast<float>(p[b] * density));
      }
      // (a, b, axis) is right-handed, so k = 0,1,2,3 runs counter-clockwise
      // seen from +axis.
      if (side > 0) {
        mesh.triangles.emplace_back(base, base + 1, base + 2);
        mesh.triangles.emplace_back(base, base + 2, base + 3);
      } else {
        mesh.triangles.emplace_back(base, base + 2, base + 1);
        mesh.triangles.emplace_back(base, base + 3, base + 2);
      }
    }
  }
  return mesh;
}

RenderMesh LoadObjRenderMesh(const std::filesystem::path& file, double scale, Eigen::Vector2d tiles) {
  const formats::ObjMesh obj = formats::ReadObjMesh(file);
  // Smooth normals for corners that give none: area-weighted face normals.
  std::vector<Eigen::Vector3d> smooth(obj.positions.size(), Eigen::Vector3d::Zero());
  for (const auto& t : obj.triangles) {
    const Eigen::Vector3d& a = obj.positions[t[0].position];
    const Eigen::Vector3d face = (obj.positions[t[1].position] - a).cross(obj.positions[t[2].position] - a);
    for (const auto& c : t) smooth[c.position] += face;
  }
  RenderMesh mesh;
  std::map<std::tuple<int, int, int>, int> vertex_of;
  for (const auto& t : obj.triangles) {
    Eigen::Vector3i triangle;
    for (int k = 0; k < 3; ++k) {
      const formats::ObjMesh::Corner& c = t[k];
      if (c.texcoord < 0)
        throw core::FormatError(file, "f", "every face corner needs a texture coordinate (v/vt or v/vt/vn)");
      const auto key = std::make_tuple(c.position, c.texcoord, c.normal);
      auto [it, inserted] = vertex_of.try_emplace(key, mesh.vertex_count());
      if (inserted) {
        const Eigen::Vector3d n = c.normal >= 0 ? obj.normals[c.normal] : smooth[c.position];
        if (!(n.norm() > 0)) throw core::FormatError(file, "vn", "a vertex has a zero normal (degenerate faces only)");
        mesh.positions.push_back((scale * obj.positions[c.position]).cast<float>());
        mesh.normals.push_back(n.normalized().cast<float>());
        mesh.texcoords.push_back(obj.texcoords[c.texcoord].cwiseProduct(tiles).cast<float>());
      }
      triangle[k] = it->second;
    }
    mesh.triangles.push_back(triangle);
  }
  return mesh;
}

void TransformMesh(const Eigen::Matrix3f& rotation, const Eigen::Vector3f& translation, RenderMesh* mesh) {
  for (auto& p : mesh->positions) p = rotation * p + translation;
  for (auto& n : mesh->normals) n = rotation * n;
  for (auto& t : mesh->tangents) t.head<3>() = rotation * t.head<3>();
}

}  // namespace mesocap::render
