#include "render/reference_renderer.h"

#include <embree3/rtcore.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "core/error.h"

namespace mesocap::render {
namespace {

// An Embree ray from origin along dir over [t0, t1], with no hit yet.
RTCRayHit RayHit(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float t0, float t1) {
  RTCRayHit hit{};
  hit.ray.org_x = origin.x();
  hit.ray.org_y = origin.y();
  hit.ray.org_z = origin.z();
  hit.ray.dir_x = dir.x();
  hit.ray.dir_y = dir.y();
  hit.ray.dir_z = dir.z();
  hit.ray.tnear = t0;
  hit.ray.tfar = t1;
  hit.ray.mask = 0xFFFFFFFF;
  hit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  return hit;
}

// A vertex of the displaced geometry with what shading needs: the base
// surface's frame and texture scale at the vertex, its depth below the
// reference surface, and where it lies in the material's sample square.
struct RefVertex {
  Eigen::Vector3f position;
  Eigen::Vector3f base_normal;
  Eigen::Vector4f base_tangent;
  Eigen::Vector2f cell{0.0f, 0.0f};  // texture coordinate within the sample square, [0, 1]
};

struct RefTriangle {
  std::array<int, 3> vertex;
  int object = 0;
  int part = -1;  // tile part; -1 for plain objects
};

// A tile triangle in the sample square's coordinates: (u, v) in [0, 1]^2
// spanning the square (u = (x + S/2) / S), z in mm.
struct SquareTriangle {
  std::array<Eigen::Vector3d, 3> p;
  int part = 0;
  Eigen::AlignedBox2d box;
};

using Polygon = std::vector<Eigen::Vector3d>;

// Sutherland-Hodgman against a u, v half-plane a u + b v + c >= 0; z is
// carried along. Works for triangles standing vertically over the (u, v)
// plane too, whose projection is a segment.
Polygon Clip(const Polygon& polygon, double a, double b, double c) {
  Polygon out;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = polygon[i];
    const Eigen::Vector3d& q = polygon[(i + 1) % n];
    const double fp = a * p.x() + b * p.y() + c;
    const double fq = a * q.x() + b * q.y() + c;
    if (fp >= 0) out.push_back(p);
    if ((fp >= 0) != (fq >= 0)) out.push_back(p + (q - p) * (fp / (fp - fq)));
  }
  return out;
}

// Every copy of the tile (period P) that reaches into the sample square
// [-S/2, S/2]^2, as SquareTriangles, bucketed on a grid over the square.
struct SquareGeometry {
  static constexpr int kGrid = 32;
  std::vector<SquareTriangle> triangles;
  std::vector<std::vector<int>> buckets{kGrid * kGrid};

  SquareGeometry(const sim::TileGeometry& g, double sample_size) {
    const double p = g.tile_size_mm, half = sample_size / 2;
    const int lo = static_cast<int>(std::floor((-half - 1.5 * p) / p));
    const int hi = static_cast<int>(std::ceil((half + 0.5 * p) / p));
    for (int m = lo; m <= hi; ++m) {
      for (int n = lo; n <= hi; ++n) {
        for (std::size_t t = 0; t < g.triangles.size(); ++t) {
          SquareTriangle s;
          s.part = g.triangle_part[t];
          for (int k = 0; k < 3; ++k) {
            const Eigen::Vector3d& v = g.vertices[g.triangles[t][k]];
            s.p[k] = {(v.x() + m * p + half) / sample_size, (v.y() + n * p + half) / sample_size, v.z()};
            s.box.extend(s.p[k].head<2>());
          }
          if (s.box.max().x() <= 0 || s.box.max().y() <= 0 || s.box.min().x() >= 1 || s.box.min().y() >= 1) continue;
          const int index = static_cast<int>(triangles.size());
          triangles.push_back(s);
          const auto [x0, y0] = Cell(s.box.min());
          const auto [x1, y1] = Cell(s.box.max());
          for (int y = y0; y <= y1; ++y) {
            for (int x = x0; x <= x1; ++x) buckets[y * kGrid + x].push_back(index);
          }
        }
      }
    }
  }
  static std::pair<int, int> Cell(const Eigen::Vector2d& uv) {
    const auto clamp = [](double c) { return std::clamp(static_cast<int>(std::floor(c * kGrid)), 0, kGrid - 1); };
    return {clamp(uv.x()), clamp(uv.y())};
  }
};

}  // namespace

struct ReferenceRenderer::Impl {
  const RenderScene* scene = nullptr;
  std::vector<RefVertex> vertices;
  std::vector<RefTriangle> triangles;
  // The reference surfaces (the meshes of objects with mesostructure), to
  // find where a shadow ray leaves the mesostructure slab.
  std::vector<Eigen::Vector3f> surface_positions;
  std::vector<Eigen::Vector3f> surface_normals;
  std::vector<std::array<int, 3>> surface_triangles;
  RTCDevice device = nullptr;
  RTCScene rtc_scene = nullptr;
  RTCScene surface_scene = nullptr;
  double epsilon = 1e-4;

  int AddVertex(const RefVertex& v) {
    vertices.push_back(v);
    return static_cast<int>(vertices.size()) - 1;
  }

  void AddPlain(const SceneObject& object, int index) {
    const RenderMesh& m = object.mesh;
    const int base = static_cast<int>(vertices.size());
    for (int i = 0; i < m.vertex_count(); ++i) {
      RefVertex v;
      v.position = m.positions[i];
      v.base_normal = m.normals[i];
      v.base_tangent = m.tangents[i];
      AddVertex(v);
    }
    for (const Eigen::Vector3i& t : m.triangles)
      triangles.push_back({{base + t[0], base + t[1], base + t[2]}, index, -1});
  }

  // Maps the material's tiles onto the mesh: for each base triangle and
  // each texture cell (a copy of the sample square) it overlaps, the tile
  // triangles are clipped to both in (u, v) and each clipped vertex goes to
  // S + s z N with the base triangle's interpolation (affine in u, v).
  void AddDisplaced(const SceneObject& object, int index, const RenderMaterial& material) {
    const SquareGeometry square(*material.geometry, material.sample_size_mm);
    const RenderMesh& m = object.mesh;
    const int first = static_cast<int>(surface_positions.size());
    surface_positions.insert(surface_positions.end(), m.positions.begin(), m.positions.end());
    surface_normals.insert(surface_normals.end(), m.normals.begin(), m.normals.end());
    for (const Eigen::Vector3i& t : m.triangles)
      surface_triangles.push_back({first + t[0], first + t[1], first + t[2]});
    std::vector<int> stamp(square.triangles.size(), -1);
    int stamp_value = 0;
    for (const Eigen::Vector3i& tri : m.triangles) {
      std::array<Eigen::Vector2d, 3> t;
      for (int k = 0; k < 3; ++k) t[k] = m.texcoords[tri[k]].cast<double>();
      const double area2 = (t[1] - t[0]).x() * (t[2] - t[0]).y() - (t[1] - t[0]).y() * (t[2] - t[0]).x();
      // A triangle with no texture area carries no mesostructure (and no
      // well-defined barycentrics in (u, v)).
      if (std::abs(area2) < 1e-14) continue;
      const double orientation = area2 > 0 ? 1.0 : -1.0;
      Eigen::AlignedBox2d box;
      for (const auto& p : t) box.extend(p);
      for (int cy = static_cast<int>(std::floor(box.min().y())); cy < box.max().y(); ++cy) {
        for (int cx = static_cast<int>(std::floor(box.min().x())); cx < box.max().x(); ++cx) {
          const Eigen::Vector2d cell(cx, cy);
          std::array<Eigen::Vector2d, 3> local;
          Eigen::AlignedBox2d local_box;
          for (int k = 0; k < 3; ++k) local_box.extend(local[k] = t[k] - cell);
          const auto [x0, y0] = SquareGeometry::Cell(local_box.min());
          const auto [x1, y1] = SquareGeometry::Cell(local_box.max());
          ++stamp_value;
          for (int y = y0; y <= y1; ++y) {
            for (int x = x0; x <= x1; ++x) {
              for (const int s : square.buckets[y * SquareGeometry::kGrid + x]) {
                if (stamp[s] == stamp_value) continue;
                stamp[s] = stamp_value;
                const SquareTriangle& st = square.triangles[s];
                if (!st.box.intersects(local_box)) continue;
                Polygon poly(st.p.begin(), st.p.end());
                poly = Clip(poly, 1, 0, 0);
                if (!poly.empty()) poly = Clip(poly, -1, 0, 1);
                if (!poly.empty()) poly = Clip(poly, 0, 1, 0);
                if (!poly.empty()) poly = Clip(poly, 0, -1, 1);
                for (int e = 0; e < 3 && !poly.empty(); ++e) {
                  const Eigen::Vector2d a = local[e], b = local[(e + 1) % 3];
                  // Inside = left of a->b for a counter-clockwise triangle.
                  const double nu = -(b.y() - a.y()) * orientation, nv = (b.x() - a.x()) * orientation;
                  poly = Clip(poly, nu, nv, -(nu * a.x() + nv * a.y()));
                }
                if (poly.size() < 3) continue;
                std::vector<int> ids;
                for (const Eigen::Vector3d& q : poly) ids.push_back(AddVertex(MapVertex(m, tri, local, area2, q)));
                for (std::size_t k = 1; k + 1 < ids.size(); ++k) {
                  const Eigen::Vector3f e1 = vertices[ids[k]].position - vertices[ids[0]].position;
                  const Eigen::Vector3f e2 = vertices[ids[k + 1]].position - vertices[ids[0]].position;
                  if (e1.cross(e2).squaredNorm() <= 0.0f) continue;
                  triangles.push_back({{ids[0], ids[k], ids[k + 1]}, index, st.part});
                }
              }
            }
          }
        }
      }
    }
  }

  static RefVertex MapVertex(const RenderMesh& m, const Eigen::Vector3i& tri, const std::array<Eigen::Vector2d, 3>& t,
                             double area2, const Eigen::Vector3d& q) {
    const auto cross = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); };
    const Eigen::Vector2d uv = q.head<2>();
    const double b1 = cross(uv - t[0], t[2] - t[0]) / area2;
    const double b2 = cross(t[1] - t[0], uv - t[0]) / area2;
    const double b0 = 1.0 - b1 - b2;
    const double b[3] = {b0, b1, b2};
    Eigen::Vector3d position = Eigen::Vector3d::Zero(), normal = Eigen::Vector3d::Zero();
    Eigen::Vector4d tangent = Eigen::Vector4d::Zero();
    double scale = 0.0;
    for (int k = 0; k < 3; ++k) {
      position += b[k] * m.positions[tri[k]].cast<double>();
      normal += b[k] * m.normals[tri[k]].cast<double>();
      tangent += b[k] * m.tangents[tri[k]].cast<double>();
      scale += b[k] * m.texture_scale[tri[k]];
    }
    normal.normalize();
    RefVertex v;
    v.position = (position + scale * q.z() * normal).cast<float>();
    v.base_normal = normal.cast<float>();
    v.base_tangent = tangent.cast<float>();
    v.base_tangent.w() = tangent.w() >= 0 ? 1.0f : -1.0f;
    v.cell = uv.cast<float>();
    return v;
  }

  // An Embree scene of one triangle geometry with `vertex_count` vertices
  // (position(k)) and `face_count` triangles (face(k)), filled straight into
  // Embree's buffers; throws Error when Embree cannot allocate or build it.
  template <typename Position, typename Face>
  RTCScene BuildScene(std::size_t vertex_count, Position position, std::size_t face_count, Face face,
                      const std::string& what) const {
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                          3 * sizeof(float), vertex_count));
    auto* i = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                             3 * sizeof(unsigned), face_count));
    if (v == nullptr || i == nullptr) {
      rtcReleaseGeometry(geometry);
      rtcReleaseScene(scene);
      throw core::Error("reference renderer: Embree cannot allocate " + what + " (" + std::to_string(face_count) +
                        " triangles)");
    }
    for (std::size_t k = 0; k < vertex_count; ++k) {
      const Eigen::Vector3f& p = position(k);
      for (int c = 0; c < 3; ++c) v[3 * k + c] = p[c];
    }
    for (std::size_t k = 0; k < face_count; ++k) {
      const std::array<int, 3>& f = face(k);
      for (int c = 0; c < 3; ++c) i[3 * k + c] = static_cast<unsigned>(f[c]);
    }
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene);
    if (rtcGetDeviceError(device) != RTC_ERROR_NONE) {
      rtcReleaseScene(scene);
      throw core::Error("reference renderer: Embree cannot build " + what);
    }
    return scene;
  }

  void Build() {
    device = rtcNewDevice(nullptr);
    if (device == nullptr) throw core::Error("reference renderer: Embree cannot create a device");
    rtc_scene = BuildScene(
        vertices.size(), [&](std::size_t k) -> const Eigen::Vector3f& { return vertices[k].position; },
        triangles.size(), [&](std::size_t k) -> const std::array<int, 3>& { return triangles[k].vertex; },
        "the displaced geometry");
    surface_scene = BuildScene(
        surface_positions.size(), [&](std::size_t k) -> const Eigen::Vector3f& { return surface_positions[k]; },
        surface_triangles.size(), [&](std::size_t k) -> const std::array<int, 3>& { return surface_triangles[k]; },
        "the reference surfaces");
  }

  // Whether the scene blocks the ray from origin along dir within (t0, t1).
  bool Blocked(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, float t0, float t1) const {
    if (!(t1 > t0)) return false;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay ray = RayHit(origin, dir, t0, t1).ray;
    rtcOccluded1(rtc_scene, &context, &ray);
    return ray.tfar < 0.0f;  // Embree marks an occluded ray with tfar = -inf
  }

  // Where the ray from p (on or under a reference surface) toward the light
  // leaves the mesostructure slab: its first crossing of the reference
  // surface going outward. Blockers before it are mesoscale self-shadowing
  // (the BTF holds them); blockers after it belong to another part of the
  // scene. The ray starts `back` behind p so a p lying on the surface (a
  // tile's top) finds its own crossing at t ~ 0; 0 when the ray never leaves
  // (it only enters a surface, or meets none: every blocker then counts).
  float SlabExit(const Eigen::Vector3f& p, const Eigen::Vector3f& dir, float back) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit hit = RayHit(p - back * dir, dir, 0.0f, std::numeric_limits<float>::infinity());
    rtcIntersect1(surface_scene, &context, &hit);
    if (hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return 0.0f;
    const std::array<int, 3>& tri = surface_triangles[hit.hit.primID];
    const Eigen::Vector3f normal = (1.0f - hit.hit.u - hit.hit.v) * surface_normals[tri[0]] +
                                   hit.hit.u * surface_normals[tri[1]] + hit.hit.v * surface_normals[tri[2]];
    if (normal.dot(dir) <= 0.0f) return 0.0f;
    return std::max(hit.ray.tfar - back, 0.0f);
  }

  // Radiance, coverage and macroscale shadow along one camera ray.
  void Trace(const Eigen::Vector3f& origin, const Eigen::Vector3f& dir, const SceneLight& light, float* rgb,
             float* coverage, float* shadow) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit hit = RayHit(origin, dir, 0.0f, std::numeric_limits<float>::infinity());
    rtcIntersect1(rtc_scene, &context, &hit);
    if (hit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return;
    *coverage = 1.0f;
    const RefTriangle& tri = triangles[hit.hit.primID];
    const RefVertex& a = vertices[tri.vertex[0]];
    const RefVertex& b = vertices[tri.vertex[1]];
    const RefVertex& c = vertices[tri.vertex[2]];
    const float u = hit.hit.u, v = hit.hit.v, w = 1.0f - u - v;
    const Eigen::Vector3f p = origin + hit.ray.tfar * dir;
    Eigen::Vector3f n = (b.position - a.position).cross(c.position - a.position).normalized();
    if (n.dot(dir) > 0) n = -n;
    const Eigen::Vector3f base_normal = (w * a.base_normal + u * b.base_normal + v * c.base_normal).normalized();
    const Eigen::Vector3f to_light = light.position.cast<float>() - p;
    const float distance = to_light.norm();
    const Eigen::Vector3f wi = to_light / distance;
    const Eigen::Vector3f wo = -dir;
    const float eps = static_cast<float>(epsilon);
    const float cos_base = base_normal.dot(wi);
    const SceneObject& object = scene->objects[tri.object];
    const bool object_plain = tri.part < 0;
    bool macro = cos_base <= 0;  // facing away from the light: attached shadow
    bool local = false;
    if (!macro) {
      // The slab is the paper's mesostructure layer; the GL renderer's shadow
      // map stores its far side along the light (Sec. 4.2), so both split
      // blockers at the slab exit. Plain objects have no slab.
      // The search beyond the exit starts a few epsilons on: where the ray
      // leaves through a tile's top, that top lies in the reference surface.
      const float exit = object_plain ? 0.0f : SlabExit(p, wi, 4 * eps);
      local = Blocked(p, wi, eps, exit);
      macro = Blocked(p, wi, exit + 4 * eps, distance - eps);
    }
    Eigen::Vector3f radiance = Eigen::Vector3f::Zero();
    if (macro) {
      *shadow = 1.0f;
      if (object_plain) {
        radiance = static_cast<float>(light.ambient) * object.albedo;
      } else {
        const RenderMaterial& m = scene->materials[object.material];
        const Eigen::Vector4f tg = w * a.base_tangent + u * b.base_tangent + v * c.base_tangent;
        const Eigen::Vector3f tangent = (tg.head<3>() - base_normal * base_normal.dot(tg.head<3>())).normalized();
        const Eigen::Vector3f bitangent = (tg.w() >= 0 ? 1.0f : -1.0f) * base_normal.cross(tangent);
        const Eigen::Vector3d local(wo.dot(tangent), wo.dot(bitangent), std::max(wo.dot(base_normal), 1e-6f));
        const Eigen::Vector2f cell = w * a.cell + u * b.cell + v * c.cell;
        const int x = std::clamp(static_cast<int>(cell.x() * m.ambient.width), 0, m.ambient.width - 1);
        const int y = std::clamp(static_cast<int>(cell.y() * m.ambient.height), 0, m.ambient.height - 1);
        radiance = static_cast<float>(light.ambient) * m.ambient.at(x, y, m.ambient.views.Nearest(local));
      }
    } else if (!local) {
      const float irradiance = static_cast<float>(light.intensity) / (distance * distance);
      const float cos_true = std::max(n.dot(wi), 0.0f);
      if (object_plain) {
        radiance = object.albedo / std::numbers::pi_v<float> * cos_true * irradiance;
      } else {
        const RenderMaterial& m = scene->materials[object.material];
        const Eigen::Vector2f cell = w * a.cell + u * b.cell + v * c.cell;
        const double half = m.sample_size_mm / 2;
        const sim::Reflectance r = sim::ReflectanceAt(*m.geometry, tri.part, cell.x() * m.sample_size_mm - half,
                                                      cell.y() * m.sample_size_mm - half);
        radiance = r.Evaluate(n.cast<double>(), wi.cast<double>(), wo.cast<double>()) * cos_true * irradiance;
      }
    }
    for (int k = 0; k < 3; ++k) rgb[k] = static_cast<float>(scene->exposure) * radiance[k];
  }
};

ReferenceRenderer::ReferenceRenderer(const RenderScene& scene) : impl_(std::make_unique<Impl>()) {
  impl_->scene = &scene;
  impl_->epsilon = 1e-5 * scene.Bounds().second;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& object = scene.objects[i];
    if (object.material < 0) {
      impl_->AddPlain(object, static_cast<int>(i));
      continue;
    }
    const RenderMaterial& material = scene.materials[object.material];
    if (!material.geometry) {
      throw core::Error("reference renderer: material " + core::Quoted(material.name) + " of object " +
                        core::Quoted(object.name) +
                        " has no true geometry (only simulated materials such as sim:brick have one)");
    }
    impl_->AddDisplaced(object, static_cast<int>(i), material);
  }
  impl_->Build();
}

ReferenceRenderer::~ReferenceRenderer() {
  if (impl_->rtc_scene != nullptr) rtcReleaseScene(impl_->rtc_scene);
  if (impl_->surface_scene != nullptr) rtcReleaseScene(impl_->surface_scene);
  if (impl_->device != nullptr) rtcReleaseDevice(impl_->device);
}

std::size_t ReferenceRenderer::triangle_count() const { return impl_->triangles.size(); }

ReferenceImage ReferenceRenderer::Render(const SceneCamera& camera, const SceneLight& light, int width,
                                         int height) const {
  ReferenceImage image{core::Image(width, height, 3), core::Image(width, height, 1), core::Image(width, height, 1)};
  const Eigen::Vector3d forward = (camera.look_at - camera.position).normalized();
  const Eigen::Vector3d right = forward.cross(camera.up).normalized();
  const Eigen::Vector3d up = right.cross(forward);
  const double tan_half = std::tan(camera.fov_y_deg * std::numbers::pi / 360.0);
  const double aspect = static_cast<double>(width) / height;
  const Eigen::Vector3f origin = camera.position.cast<float>();
  tbb::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y) {
      for (int x = 0; x < width; ++x) {
        // Pixel centres, as the GL rasterizer samples them.
        const double ndc_x = 2.0 * (x + 0.5) / width - 1.0;
        const double ndc_y = 1.0 - 2.0 * (y + 0.5) / height;
        const Eigen::Vector3d dir = (forward + ndc_x * tan_half * aspect * right + ndc_y * tan_half * up).normalized();
        impl_->Trace(origin, dir.cast<float>(), light, image.color.pixel(x, y), image.coverage.pixel(x, y),
                     image.shadow.pixel(x, y));
      }
    }
  });
  return image;
}

}  // namespace mesocap::render
