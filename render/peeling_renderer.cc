#include "render/peeling_renderer.h"

#include <epoxy/gl.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <initializer_list>
#include <numbers>
#include <vector>

#include "core/angles.h"
#include "core/error.h"
#include "render/direction_blend_table.h"
#include "render/peeling_shaders.h"

namespace mesocap::render {
namespace {

// The stencil holds the pass that finished a pixel (1..254); 255 = not yet.
constexpr int kStencilOpen = 255;
constexpr int kMaxStencilPasses = 254;
// The depth buffer's far end (reversed depth, see Perspective).
constexpr float kFarthestDepth = 0.0f;

Eigen::Matrix4f LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up) {
  const Eigen::Vector3d f = (target - eye).normalized();
  const Eigen::Vector3d s = f.cross(up).normalized();
  const Eigen::Vector3d u = s.cross(f);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<1, 3>(0, 0) = s.transpose();
  m.block<1, 3>(1, 0) = u.transpose();
  m.block<1, 3>(2, 0) = -f.transpose();
  m(0, 3) = -s.dot(eye);
  m(1, 3) = -u.dot(eye);
  m(2, 3) = f.dot(eye);
  return m.cast<float>();
}

// Reversed depth (near -> 1, far -> 0, with glClipControl's zero-to-one
// range): a float depth buffer then resolves the far end as finely as the
// near one, where the surfaces at the far plane (a floor) would otherwise
// round to the cleared depth and vanish.
Eigen::Matrix4f Perspective(double fov_y, double aspect, double near, double far) {
  const double f = 1.0 / std::tan(fov_y / 2);
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m(0, 0) = f / aspect;
  m(1, 1) = f;
  m(2, 2) = near / (far - near);
  m(2, 3) = far * near / (far - near);
  m(3, 2) = -1;
  return m.cast<float>();
}

// An eye (camera or light) for one peeling sweep.
struct Eye {
  Eigen::Matrix4f view_proj;
  Eigen::Vector3f position;
  float far = 1.0f;
};

GLuint Compile(GLenum type, std::initializer_list<const char*> sources) {
  const GLuint shader = glCreateShader(type);
  const std::vector<const char*> parts(sources);
  glShaderSource(shader, static_cast<GLsizei>(parts.size()), parts.data(), nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    glDeleteShader(shader);
    throw core::Error(std::string("peeling renderer: the OpenGL driver rejects a shader: ") + log);
  }
  return shader;
}

GLuint MakeTexture2d(GLenum format, int width, int height) {
  GLuint texture = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &texture);
  glTextureStorage2D(texture, 1, format, width, height);
  glTextureParameteri(texture, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(texture, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  glTextureParameteri(texture, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(texture, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
}

GLuint MakeTextureArray(GLenum internal_format, GLenum format, int width, int height, int layers, const float* data) {
  GLint max_layers = 0;
  glGetIntegerv(GL_MAX_ARRAY_TEXTURE_LAYERS, &max_layers);
  if (layers > max_layers) {
    throw core::Error("peeling renderer: the material needs " + std::to_string(layers) +
                      " texture array layers; the OpenGL driver allows " + std::to_string(max_layers));
  }
  GLuint texture = 0;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &texture);
  glTextureStorage3D(texture, 1, internal_format, width, height, layers);
  glTextureSubImage3D(texture, 0, 0, 0, 0, width, height, layers, format, GL_FLOAT, data);
  glTextureParameteri(texture, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(texture, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  return texture;
}

// A linked program and its uniforms.
struct GlProgram {
  GLuint id = 0;

  void Link(GLuint vertex, GLuint fragment) {
    id = glCreateProgram();
    glAttachShader(id, vertex);
    glAttachShader(id, fragment);
    glLinkProgram(id);
    GLint ok = 0;
    glGetProgramiv(id, GL_LINK_STATUS, &ok);
    if (!ok) {
      char log[4096];
      glGetProgramInfoLog(id, sizeof log, nullptr, log);
      throw core::Error(std::string("peeling renderer: the OpenGL driver cannot link a program: ") + log);
    }
  }
  GLint Uniform(const char* name) const { return glGetUniformLocation(id, name); }
  void Set(const char* name, int v) const { glProgramUniform1i(id, Uniform(name), v); }
  void Set(const char* name, float v) const { glProgramUniform1f(id, Uniform(name), v); }
  void Set(const char* name, const Eigen::Vector3f& v) const { glProgramUniform3fv(id, Uniform(name), 1, v.data()); }
  void Set(const char* name, const Eigen::Matrix3f& m) const {
    glProgramUniformMatrix3fv(id, Uniform(name), 1, GL_FALSE, m.data());
  }
  void Set(const char* name, const Eigen::Matrix4f& m) const {
    glProgramUniformMatrix4fv(id, Uniform(name), 1, GL_FALSE, m.data());
  }
};

struct BlendTextures {
  GLuint index = 0;
  GLuint weight = 0;
};

BlendTextures MakeBlendTextures(const core::SamplingSet& set) {
  const DirectionBlendTable table = MakeDirectionBlendTable(set);
  BlendTextures t;
  glCreateTextures(GL_TEXTURE_2D, 1, &t.index);
  glTextureStorage2D(t.index, 1, GL_RGBA32I, table.phi_cells, table.theta_cells);
  glTextureSubImage2D(t.index, 0, 0, 0, table.phi_cells, table.theta_cells, GL_RGBA_INTEGER, GL_INT,
                      table.index.data());
  // Integer textures are incomplete (read as 0) with the default mipmapped filter.
  glTextureParameteri(t.index, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(t.index, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  t.weight = MakeTexture2d(GL_RGBA32F, table.phi_cells, table.theta_cells);
  glTextureSubImage2D(t.weight, 0, 0, 0, table.phi_cells, table.theta_cells, GL_RGBA, GL_FLOAT, table.weight.data());
  return t;
}

struct GpuMaterial {
  GLuint mdf = 0, rows = 0, columns = 0, ambient = 0;
  GLuint clusters = 0;  // clustered layout: each texel's cluster (else 1x1, unused)
  BlendTextures views, lights;
  int rank = 0;
  int light_count = 0;
  int view_count = 0;
  int layout = 0;  // as the shader's u_layout: 0 paper, 1 per_texel, 2 clustered, 3 per_view
  Eigen::Matrix3f factored_to_rgb = Eigen::Matrix3f::Identity();
  float d_max = 0.0f;
};

GpuMaterial Upload(const RenderMaterial& m) {
  m.btf.CheckShape();
  GpuMaterial g;
  // MDF: no hit -> -1; unknown -> 0, i.e. the reference surface, which is
  // what BTF-only rendering assumes everywhere.
  std::vector<float> mdf(m.mdf.distance_mm.data(), m.mdf.distance_mm.data() + m.mdf.distance_mm.size());
  for (float& d : mdf) d = core::IsNoHit(d) ? -1.0f : (core::IsUnknown(d) ? 0.0f : d);
  g.mdf = MakeTextureArray(GL_R32F, GL_RED, m.mdf.width, m.mdf.height, m.mdf.view_count(), mdf.data());
  const core::FactoredBtf& btf = m.btf;
  static_assert(static_cast<int>(core::BtfFactorLayout::kPerView) == 3, "u_layout follows the enum's order");
  g.layout = static_cast<int>(btf.layout);
  g.rank = btf.rank();
  g.light_count = btf.light_count();
  g.view_count = btf.view_count();
  // Each row image is one layer per stacked light (paper) or view (per_view).
  const int layers_per_k = btf.row_image_height() / btf.height;
  std::vector<float> clusters(btf.texel_clusters.begin(), btf.texel_clusters.end());
  if (clusters.empty()) clusters.assign(1, 0.0f);
  const bool clustered = g.layout == 2;
  g.clusters = MakeTexture2d(GL_R32F, clustered ? btf.width : 1, clustered ? btf.height : 1);
  glTextureSubImage2D(g.clusters, 0, 0, 0, clustered ? btf.width : 1, clustered ? btf.height : 1, GL_RED, GL_FLOAT,
                      clusters.data());
  std::vector<float> rows;
  rows.reserve(static_cast<std::size_t>(btf.rank()) * btf.rows[0].size());
  for (const core::Image& r : btf.rows) rows.insert(rows.end(), r.data(), r.data() + r.size());
  g.rows = MakeTextureArray(GL_RGB32F, GL_RGB, btf.width, btf.height, btf.rank() * layers_per_k, rows.data());
  g.columns = MakeTexture2d(GL_RGB32F, btf.columns.width(), btf.columns.height());
  glTextureSubImage2D(g.columns, 0, 0, 0, btf.columns.width(), btf.columns.height(), GL_RGB, GL_FLOAT,
                      btf.columns.data());
  if (btf.color != core::BtfFactorColor::kRgb) g.factored_to_rgb = btf.rgb_to_factored.inverse().cast<float>();
  g.ambient = MakeTextureArray(GL_RGB32F, GL_RGB, m.ambient.width, m.ambient.height, m.ambient.view_count(),
                               m.ambient.values.data());
  g.views = MakeBlendTextures(m.mdf.views);
  g.lights = MakeBlendTextures(btf.lights);
  g.d_max = static_cast<float>(m.d_max_mm);
  return g;
}

struct GpuMesh {
  GLuint vao = 0, vbo = 0, ebo = 0;
  GLsizei index_count = 0;
  int material = -1;
  Eigen::Vector3f albedo;
};

GpuMesh Upload(const SceneObject& object) {
  const RenderMesh& m = object.mesh;
  std::vector<float> vertices;
  vertices.reserve(static_cast<std::size_t>(m.vertex_count()) * 13);
  for (int i = 0; i < m.vertex_count(); ++i) {
    const float v[13] = {m.positions[i].x(), m.positions[i].y(), m.positions[i].z(), m.normals[i].x(),
                         m.normals[i].y(),   m.normals[i].z(),   m.texcoords[i].x(), m.texcoords[i].y(),
                         m.tangents[i].x(),  m.tangents[i].y(),  m.tangents[i].z(),  m.tangents[i].w(),
                         m.texture_scale[i]};
    vertices.insert(vertices.end(), v, v + 13);
  }
  GpuMesh g;
  g.material = object.material;
  g.albedo = object.albedo;
  g.index_count = static_cast<GLsizei>(m.triangles.size() * 3);
  glCreateBuffers(1, &g.vbo);
  glNamedBufferStorage(g.vbo, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)), vertices.data(), 0);
  glCreateBuffers(1, &g.ebo);
  glNamedBufferStorage(g.ebo, static_cast<GLsizeiptr>(m.triangles.size() * sizeof(Eigen::Vector3i)), m.triangles.data(),
                       0);
  glCreateVertexArrays(1, &g.vao);
  glVertexArrayVertexBuffer(g.vao, 0, g.vbo, 0, 13 * sizeof(float));
  glVertexArrayElementBuffer(g.vao, g.ebo);
  const int sizes[5] = {3, 3, 2, 4, 1};
  int offset = 0;
  for (int a = 0; a < 5; ++a) {
    glEnableVertexArrayAttrib(g.vao, a);
    glVertexArrayAttribFormat(g.vao, a, sizes[a], GL_FLOAT, GL_FALSE, offset * sizeof(float));
    glVertexArrayAttribBinding(g.vao, a, 0);
    offset += sizes[a];
  }
  return g;
}

// The render targets of one peeling sweep (view or light): Fig. 7's two peel
// depth buffers (ping-pong), z_pb - d_b, the output colour and masks, a
// shared depth-stencil buffer, and for the view the surface the resolve pass
// shades.
struct PeelTargets {
  int width = 0, height = 0;
  GLuint zpeel[2] = {0, 0};
  GLuint zbo = 0;
  GLuint color = 0;       // view RGBA32F: colour; light R32F: shadow depth
  GLuint masks = 0;       // view RGBA32F: coverage, shadow; light R8: a layer found
  GLuint surface = 0;     // view, RGBA32F: texture coordinates, irradiance (-1: shadow), material + 1
  GLuint directions = 0;  // view, RGBA32F: local view and light (theta, phi)
  GLuint depth_stencil = 0;
  GLuint back_fbo = 0, front_fbo = 0;
  GLuint finish_fbo = 0;   // the stencil alone, for the finishing pass
  GLuint resolve_fbo = 0;  // view: the colour alone, for the resolve pass

  void Create(int w, int h, bool view) {
    width = w;
    height = h;
    for (GLuint& z : zpeel) z = MakeTexture2d(GL_R32F, w, h);
    zbo = MakeTexture2d(GL_R32F, w, h);
    // The light's targets hold one value a texel: a quarter of the memory
    // traffic of its clears, peel passes and finishing passes.
    color = MakeTexture2d(view ? GL_RGBA32F : GL_R32F, w, h);
    masks = MakeTexture2d(view ? GL_RGBA32F : GL_R8, w, h);
    glCreateRenderbuffers(1, &depth_stencil);
    glNamedRenderbufferStorage(depth_stencil, GL_DEPTH32F_STENCIL8, w, h);
    glCreateFramebuffers(1, &back_fbo);
    glNamedFramebufferTexture(back_fbo, GL_COLOR_ATTACHMENT1, zbo, 0);
    glNamedFramebufferRenderbuffer(back_fbo, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth_stencil);
    const GLenum attachments[4] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2,
                                   GL_COLOR_ATTACHMENT3};
    glNamedFramebufferDrawBuffers(back_fbo, 2, attachments);
    glCreateFramebuffers(1, &front_fbo);
    glNamedFramebufferTexture(front_fbo, GL_COLOR_ATTACHMENT0, color, 0);
    glNamedFramebufferTexture(front_fbo, GL_COLOR_ATTACHMENT1, masks, 0);
    if (view) {
      surface = MakeTexture2d(GL_RGBA32F, w, h);
      directions = MakeTexture2d(GL_RGBA32F, w, h);
      glNamedFramebufferTexture(front_fbo, GL_COLOR_ATTACHMENT2, surface, 0);
      glNamedFramebufferTexture(front_fbo, GL_COLOR_ATTACHMENT3, directions, 0);
      glCreateFramebuffers(1, &resolve_fbo);
      glNamedFramebufferTexture(resolve_fbo, GL_COLOR_ATTACHMENT0, color, 0);
      glNamedFramebufferDrawBuffers(resolve_fbo, 1, attachments);
    }
    glNamedFramebufferRenderbuffer(front_fbo, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth_stencil);
    glNamedFramebufferDrawBuffers(front_fbo, view ? 4 : 2, attachments);
    glCreateFramebuffers(1, &finish_fbo);
    glNamedFramebufferRenderbuffer(finish_fbo, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, depth_stencil);
    glNamedFramebufferDrawBuffer(finish_fbo, GL_NONE);
    if (glCheckNamedFramebufferStatus(front_fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE ||
        glCheckNamedFramebufferStatus(finish_fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
      throw core::Error(
          "peeling renderer: the OpenGL driver cannot render to float colour with a float depth + stencil "
          "buffer (GL_DEPTH32F_STENCIL8)");
    }
  }
  bool is_view() const { return surface != 0; }
  // Clears what the front faces write: the view's colour, masks and surface
  // to zero; the light's shadow depth to far (1) and its mask to zero.
  void ClearOutputs() const {
    const GLfloat zero[4] = {0, 0, 0, 0};
    const GLfloat far_value[4] = {1, 1, 1, 1};
    glClearNamedFramebufferfv(front_fbo, GL_COLOR, 0, is_view() ? zero : far_value);
    for (int attachment = 1; attachment < (is_view() ? 4 : 2); ++attachment) {
      glClearNamedFramebufferfv(front_fbo, GL_COLOR, attachment, zero);
    }
  }
  void Destroy() {
    const GLuint fbos[4] = {back_fbo, front_fbo, finish_fbo, resolve_fbo};
    glDeleteFramebuffers(4, fbos);
    glDeleteRenderbuffers(1, &depth_stencil);
    const GLuint textures[7] = {zpeel[0], zpeel[1], zbo, color, masks, surface, directions};
    glDeleteTextures(7, textures);
    *this = PeelTargets{};
  }
};

}  // namespace

core::CheckResult PeelingOptions::Check() const {
  if (width < 1 || height < 1 || width > 8192 || height > 8192) {
    return "image size must be in [1, 8192] per side, got " + std::to_string(width) + "x" + std::to_string(height);
  }
  if (passes < 0 || passes > kMaxStencilPasses) {
    return "passes must be 0 (adaptive) or in [1, 254], got " + std::to_string(passes);
  }
  if (max_passes < 1 || max_passes > kMaxStencilPasses) {
    return "max_passes must be in [1, 254], got " + std::to_string(max_passes);
  }
  if (shadow_map_size < 16 || shadow_map_size > 8192) {
    return "shadow_map_size must be in [16, 8192], got " + std::to_string(shadow_map_size);
  }
  return {};
}

struct PeelingRenderer::Impl {
  GlProgram peeling, finishing, resolve;
  GLuint empty_vao = 0;  // full-screen passes draw without vertex attributes
  GLuint query = 0;
  std::vector<GpuMesh> meshes;
  std::vector<GpuMaterial> materials;
  PeelTargets view, light;
  Eigen::Vector3d centre;
  double radius = 1.0;

  // Draws every object with `kind`, culling `cull` faces.
  void DrawObjects(int kind, GLenum cull) const {
    peeling.Set("u_kind", kind);
    glEnable(GL_CULL_FACE);
    glCullFace(cull);
    for (const GpuMesh& mesh : meshes) {
      const bool textured = mesh.material >= 0;
      peeling.Set("u_has_material", textured ? 1 : 0);
      peeling.Set("u_albedo", mesh.albedo);
      if (textured) {
        const GpuMaterial& m = materials[mesh.material];
        glBindTextureUnit(2, m.mdf);
        glBindTextureUnit(6, m.views.index);
        glBindTextureUnit(7, m.views.weight);
        peeling.Set("u_material", mesh.material);
        peeling.Set("u_d_max", m.d_max);
      } else {
        peeling.Set("u_d_max", 0.0f);
      }
      glBindVertexArray(mesh.vao);
      glDrawElements(GL_TRIANGLES, mesh.index_count, GL_UNSIGNED_INT, nullptr);
    }
  }

  void UseEye(const Eye& eye) const {
    peeling.Set("u_view_proj", eye.view_proj);
    peeling.Set("u_eye", eye.position);
    peeling.Set("u_far", eye.far);
  }

  // Records `pass` in the stencil of the open pixels whose front faces found
  // a layer in it. The peel passes only test the stencil, never write it, so
  // that the driver may run the depth and stencil tests before their
  // fragment shader, which is most of the cost of a pass.
  void Finish(const PeelTargets& t, int pass) const {
    glBindFramebuffer(GL_FRAMEBUFFER, t.finish_fbo);
    glUseProgram(finishing.id);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_CULL_FACE);
    glStencilMask(0xFF);
    glStencilFunc(GL_LEQUAL, pass, 0xFF);
    glStencilOp(GL_KEEP, GL_KEEP, GL_REPLACE);
    glBindTextureUnit(0, t.masks);
    glBindVertexArray(empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glStencilMask(0);
    glEnable(GL_DEPTH_TEST);
    glUseProgram(peeling.id);
  }

  // Shades every shown pixel of the view once, material by material, from
  // the surface the view pass left (plain surfaces are already shaded).
  void Resolve() const {
    glBindFramebuffer(GL_FRAMEBUFFER, view.resolve_fbo);
    glViewport(0, 0, view.width, view.height);
    glUseProgram(resolve.id);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_STENCIL_TEST);
    glDisable(GL_CULL_FACE);
    glBindTextureUnit(12, view.surface);
    glBindTextureUnit(13, view.directions);
    glBindVertexArray(empty_vao);
    for (std::size_t i = 0; i < materials.size(); ++i) {
      const GpuMaterial& m = materials[i];
      glBindTextureUnit(3, m.rows);
      glBindTextureUnit(4, m.columns);
      glBindTextureUnit(5, m.ambient);
      glBindTextureUnit(6, m.views.index);
      glBindTextureUnit(7, m.views.weight);
      glBindTextureUnit(8, m.lights.index);
      glBindTextureUnit(9, m.lights.weight);
      glBindTextureUnit(11, m.clusters);
      resolve.Set("u_material", static_cast<int>(i));
      resolve.Set("u_rank", m.rank);
      resolve.Set("u_light_count", m.light_count);
      resolve.Set("u_view_count", m.view_count);
      resolve.Set("u_layout", m.layout);
      resolve.Set("u_factored_to_rgb", m.factored_to_rgb);
      glDrawArrays(GL_TRIANGLES, 0, 3);
    }
  }

  // Fig. 7, front to back. Returns the passes run: `fixed` of them, or with
  // fixed == 0 until a back-face pass finds no layer behind Zpeel_now for an
  // unfinished pixel (occlusion query), at most `cap`.
  int Peel(PeelTargets& t, const Eye& eye, int front_kind, int fixed, int cap) const {
    glViewport(0, 0, t.width, t.height);
    UseEye(eye);
    const float minus_one = -1.0f;
    glClearTexImage(t.zpeel[0], 0, GL_RED, GL_FLOAT, &minus_one);  // Zpeel_now: nothing peeled yet
    const GLfloat far_value[4] = {1, 1, 1, 1};
    t.ClearOutputs();
    glStencilMask(0xFF);  // clears obey the write masks
    glDepthMask(GL_TRUE);
    const GLint open = kStencilOpen;
    glClearNamedFramebufferiv(t.front_fbo, GL_STENCIL, 0, &open);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GREATER);
    glEnable(GL_STENCIL_TEST);
    glStencilMask(0);
    glStencilOp(GL_KEEP, GL_KEEP, GL_KEEP);
    int now = 0;
    int passes = 0;
    const int limit = fixed > 0 ? fixed : cap;
    for (int pass = 1; pass <= limit; ++pass) {
      const int next = 1 - now;
      // Back faces: the nearest beyond Zpeel_now among unfinished pixels
      // (stencil still open: pass <= stencil).
      glNamedFramebufferTexture(t.back_fbo, GL_COLOR_ATTACHMENT0, t.zpeel[next], 0);
      glBindFramebuffer(GL_FRAMEBUFFER, t.back_fbo);
      glClearNamedFramebufferfv(t.back_fbo, GL_COLOR, 0, far_value);  // no back face: Zpeel_next = far
      glClearNamedFramebufferfv(t.back_fbo, GL_COLOR, 1, &minus_one);
      glClearNamedFramebufferfv(t.back_fbo, GL_DEPTH, 0, &kFarthestDepth);
      glStencilFunc(GL_LEQUAL, pass, 0xFF);
      glBindTextureUnit(0, t.zpeel[now]);
      if (fixed == 0) glBeginQuery(GL_ANY_SAMPLES_PASSED, query);
      DrawObjects(kPassBackPeel, GL_FRONT);
      if (fixed == 0) {
        glEndQuery(GL_ANY_SAMPLES_PASSED);
        GLuint any = 0;
        glGetQueryObjectuiv(query, GL_QUERY_RESULT, &any);
        if (any == 0) break;
      }
      // Front faces: in front of z_pb (depth test), behind Zpeel_now, and
      // hitting the mesostructure (z_pf + d_f <= z_pb - d_b) -> output; then
      // the stencil records the pass so later layers leave the pixel alone.
      glBindFramebuffer(GL_FRAMEBUFFER, t.front_fbo);
      glBindTextureUnit(1, t.zbo);
      DrawObjects(front_kind, GL_BACK);
      Finish(t, pass);
      now = next;
      ++passes;
    }
    glStencilMask(0xFF);
    glDisable(GL_STENCIL_TEST);
    return passes;
  }

  // One pass over the nearest front faces (BTF only, or the plain shadow map).
  void Plain(PeelTargets& t, const Eye& eye, int kind) const {
    glViewport(0, 0, t.width, t.height);
    UseEye(eye);
    glDepthMask(GL_TRUE);  // clears obey the write mask
    glBindFramebuffer(GL_FRAMEBUFFER, t.front_fbo);
    t.ClearOutputs();
    glClearNamedFramebufferfv(t.front_fbo, GL_DEPTH, 0, &kFarthestDepth);
    glDisable(GL_STENCIL_TEST);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_GREATER);
    glDepthMask(GL_TRUE);
    DrawObjects(kind, GL_BACK);
  }

  RenderResult Frame(const SceneCamera& camera, const SceneLight& scene_light, const PeelingOptions& options) {
    core::ThrowIfInvalid(options.Check(), "render");
    if (view.width != options.width || view.height != options.height) {
      if (view.width > 0) view.Destroy();
      view.Create(options.width, options.height, true);
    }
    if (light.width != options.shadow_map_size) {
      if (light.width > 0) light.Destroy();
      light.Create(options.shadow_map_size, options.shadow_map_size, false);
    }
    // Camera: far plane beyond the scene's bounding sphere, so t < 1.
    Eye cam;
    const double camera_far = (camera.position - centre).norm() + 2.0 * radius;
    const double near = std::max(1e-4 * camera_far, (camera.position - centre).norm() - 1.5 * radius);
    cam.view_proj = Perspective(core::RadiansFromDegrees(camera.fov_y_deg), double(options.width) / options.height,
                                near, camera_far) *
                    LookAt(camera.position, camera.look_at, camera.up);
    cam.position = camera.position.cast<float>();
    cam.far = static_cast<float>(camera_far);
    // Light: a perspective shadow map aimed at the scene, covering its
    // bounding sphere (the light is expected outside it).
    Eye lamp;
    const Eigen::Vector3d to_centre = centre - scene_light.position;
    const double light_distance = std::max(to_centre.norm(), 1.01 * radius);
    const double half_angle = std::asin(std::min(radius / light_distance, 0.99));
    const Eigen::Vector3d light_up =
        std::abs(to_centre.normalized().z()) > 0.9 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
    const double light_far = light_distance + 2.0 * radius;
    lamp.view_proj =
        Perspective(2 * half_angle, 1.0, std::max(1e-4 * light_far, light_distance - 1.5 * radius), light_far) *
        LookAt(scene_light.position, centre, light_up);
    lamp.position = scene_light.position.cast<float>();
    lamp.far = static_cast<float>(light_far);

    glFinish();
    const auto start = std::chrono::steady_clock::now();
    glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glUseProgram(peeling.id);
    RenderResult result;
    if (options.mode == RenderMode::kFull) {
      result.shadow_passes = Peel(light, lamp, kPassShadowFrontPeel, options.passes, options.max_passes);
    } else {
      Plain(light, lamp, kPassShadowPlain);
      result.shadow_passes = 1;
    }
    peeling.Set("u_light_position", lamp.position);
    peeling.Set("u_light_intensity", static_cast<float>(scene_light.intensity));
    peeling.Set("u_light_view_proj", lamp.view_proj);
    peeling.Set("u_light_far", lamp.far);
    peeling.Set("u_shadow_texel", static_cast<float>(2.0 * std::tan(half_angle) / options.shadow_map_size));
    peeling.Set("u_shadow_at_mesostructure", options.mode == RenderMode::kFull ? 1 : 0);
    for (const GlProgram* program : {&peeling, &resolve}) {
      program->Set("u_ambient_scale", static_cast<float>(scene_light.ambient));
    }
    glBindTextureUnit(10, light.color);
    if (options.mode == RenderMode::kBtf) {
      Plain(view, cam, kPassSurface);
      result.passes = 1;
    } else {
      result.passes = Peel(view, cam, kPassFrontPeel, options.passes, options.max_passes);
    }
    glBindTextureUnit(10, 0);
    Resolve();
    glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);  // the context's default, for its other users
    glFinish();
    result.frame_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (const GLenum error = glGetError(); error != GL_NO_ERROR) {
      throw core::Error("peeling renderer: OpenGL error " + std::to_string(error) + " while rendering");
    }
    return result;
  }
};

PeelingRenderer::PeelingRenderer(const RenderScene& scene) : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  const GLuint mesh_vertices = Compile(GL_VERTEX_SHADER, {kGlslVersion, kPeelingVertexShader});
  const GLuint full_screen = Compile(GL_VERTEX_SHADER, {kGlslVersion, kFullScreenVertexShader});
  const GLuint peeling = Compile(GL_FRAGMENT_SHADER, {kGlslVersion, kDirectionGlsl, kPeelingFragmentShader});
  const GLuint finishing = Compile(GL_FRAGMENT_SHADER, {kGlslVersion, kFinishingFragmentShader});
  const GLuint resolve = Compile(GL_FRAGMENT_SHADER, {kGlslVersion, kDirectionGlsl, kResolveFragmentShader});
  s.peeling.Link(mesh_vertices, peeling);
  s.finishing.Link(full_screen, finishing);
  s.resolve.Link(full_screen, resolve);
  for (const GLuint shader : {mesh_vertices, full_screen, peeling, finishing, resolve}) glDeleteShader(shader);
  // One texture unit per sampler across the programs.
  const char* samplers[] = {"u_peel_now",   "u_zbo",        "u_mdf",         "u_rows",        "u_columns",
                            "u_ambient",    "u_view_index", "u_view_weight", "u_light_index", "u_light_weight",
                            "u_shadow_map", "u_clusters",   "u_surface",     "u_directions"};
  for (int unit = 0; unit < 14; ++unit) {
    for (const GlProgram* program : {&s.peeling, &s.resolve}) {
      if (program->Uniform(samplers[unit]) >= 0) program->Set(samplers[unit], unit);
    }
  }
  s.finishing.Set("u_found", 0);
  for (const GlProgram* program : {&s.peeling, &s.resolve}) {
    program->Set("u_exposure", static_cast<float>(scene.exposure));
  }
  glCreateVertexArrays(1, &s.empty_vao);
  glCreateQueries(GL_ANY_SAMPLES_PASSED, 1, &s.query);
  for (const RenderMaterial& m : scene.materials) s.materials.push_back(Upload(m));
  for (const SceneObject& o : scene.objects) s.meshes.push_back(Upload(o));
  std::tie(s.centre, s.radius) = scene.Bounds();
  if (const GLenum error = glGetError(); error != GL_NO_ERROR) {
    throw core::Error("peeling renderer: OpenGL error " + std::to_string(error) + " while uploading the scene");
  }
}

PeelingRenderer::~PeelingRenderer() {
  Impl& s = *impl_;
  if (s.view.width > 0) s.view.Destroy();
  if (s.light.width > 0) s.light.Destroy();
  for (const GpuMesh& m : s.meshes) {
    glDeleteVertexArrays(1, &m.vao);
    glDeleteBuffers(1, &m.vbo);
    glDeleteBuffers(1, &m.ebo);
  }
  for (const GpuMaterial& m : s.materials) {
    const GLuint textures[9] = {m.mdf,          m.rows,         m.columns,       m.ambient, m.views.index,
                                m.views.weight, m.lights.index, m.lights.weight, m.clusters};
    glDeleteTextures(9, textures);
  }
  glDeleteQueries(1, &s.query);
  glDeleteVertexArrays(1, &s.empty_vao);
  for (const GlProgram* program : {&s.peeling, &s.finishing, &s.resolve}) glDeleteProgram(program->id);
}

RenderResult PeelingRenderer::Draw(const SceneCamera& camera, const SceneLight& light, const PeelingOptions& options) {
  return impl_->Frame(camera, light, options);
}

RenderResult PeelingRenderer::Render(const SceneCamera& camera, const SceneLight& light,
                                     const PeelingOptions& options) {
  RenderResult result = impl_->Frame(camera, light, options);
  const int w = options.width, h = options.height;
  std::vector<float> rgba(static_cast<std::size_t>(w) * h * 4), masks(rgba.size());
  glGetTextureImage(impl_->view.color, 0, GL_RGBA, GL_FLOAT, static_cast<GLsizei>(rgba.size() * sizeof(float)),
                    rgba.data());
  glGetTextureImage(impl_->view.masks, 0, GL_RGBA, GL_FLOAT, static_cast<GLsizei>(masks.size() * sizeof(float)),
                    masks.data());
  result.color = core::Image(w, h, 3);
  result.coverage = core::Image(w, h, 1);
  result.shadow = core::Image(w, h, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const std::size_t i = (static_cast<std::size_t>(h - 1 - y) * w + x) * 4;  // GL rows run bottom-up
      for (int c = 0; c < 3; ++c) result.color.at(x, y, c) = rgba[i + c];
      result.coverage.at(x, y) = masks[i];
      result.shadow.at(x, y) = masks[i + 1];
    }
  }
  return result;
}

void PeelingRenderer::Present(int window_width, int window_height) {
  const PeelTargets& v = impl_->view;
  glNamedFramebufferReadBuffer(v.front_fbo, GL_COLOR_ATTACHMENT0);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glBlitNamedFramebuffer(v.front_fbo, 0, 0, 0, v.width, v.height, 0, 0, window_width, window_height,
                         GL_COLOR_BUFFER_BIT, GL_LINEAR);
}

}  // namespace mesocap::render
